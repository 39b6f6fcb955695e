#include "cpgmatch/dds/domain.hpp"

#include <cstdlib>

#include <fmt/format.h>

#include "cpgmatch/errors.hpp"

namespace cpgmatch::dds {

void validate_domain(int domain, const std::string& what) {
  if (domain < 0 || domain > kMaxDomainId) {
    throw InputError(fmt::format("{}: domain id {} is outside 0..{}", what, domain, kMaxDomainId));
  }
}

int default_domain() {
  const char* text = std::getenv("CPGMATCH_DOMAIN");
  if (text == nullptr || *text == '\0') return 0;
  char* end = nullptr;
  const long value = std::strtol(text, &end, 10);
  if (*end != '\0') throw InputError(fmt::format("CPGMATCH_DOMAIN: '{}' is not a domain id", text));
  validate_domain(static_cast<int>(value), "CPGMATCH_DOMAIN");
  return static_cast<int>(value);
}

}  // namespace cpgmatch::dds
