#include "cpgmatch/runtime/install_layout.hpp"

#include <unistd.h>

#include <cstdlib>
#include <system_error>

#include <fmt/format.h>

#include "cpgmatch/errors.hpp"

namespace cpgmatch::runtime {

namespace fs = std::filesystem;

namespace {

// <prefix>/share/cpgmatch/<what> if this executable sits in an installed prefix, else empty.
fs::path installed_data(const char* what) {
  std::error_code ec;
  const fs::path dir = (executable_dir() / CPGMATCH_BIN_TO_DATA / what).lexically_normal();
  return fs::is_directory(dir, ec) ? dir : fs::path();
}

}  // namespace

fs::path executable_dir() {
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  return ec ? fs::current_path() : exe.parent_path();
}

fs::path config_dir() {
  if (const char* env = std::getenv("CPGMATCH_CONFIG_DIR"); env != nullptr && *env != '\0') {
    std::error_code ec;
    if (!fs::is_directory(env, ec)) {
      throw InputError(fmt::format("CPGMATCH_CONFIG_DIR: '{}' is not a folder", env));
    }
    return env;
  }
  if (fs::path installed = installed_data("configs"); !installed.empty()) return installed;
  return CPGMATCH_SOURCE_CONFIG_DIR;
}

fs::path fastdds_profiles_dir() {
  if (fs::path installed = installed_data("fastdds"); !installed.empty()) return installed;
  return CPGMATCH_SOURCE_FASTDDS_DIR;
}

fs::path pki_script() {
  std::error_code ec;
  const fs::path installed = (executable_dir() / CPGMATCH_BIN_TO_DATA / "make-study-pki.sh").lexically_normal();
  if (fs::is_regular_file(installed, ec)) return installed;
  return CPGMATCH_SOURCE_PKI_SCRIPT;
}

void export_config_dir() {
  // The simulation library reads the folder from this variable (falling back to the source tree it
  // was built from), and child processes inherit it: one place decides for the whole process tree.
  setenv("CPGMATCH_CONFIG_DIR", config_dir().c_str(), 1);
}

}  // namespace cpgmatch::runtime
