#include "cpgmatch/runtime/version.hpp"

#include <fmt/format.h>

namespace cpgmatch::runtime {

const char* project_version() { return CPGMATCH_VERSION; }

std::string version_text(const std::string& program) {
  return fmt::format("{} {} (git {})", program, project_version(), git_revision());
}

}  // namespace cpgmatch::runtime
