#include "cpgmatch/dds/domain.hpp"

#include <cerrno>
#include <cstdlib>
#include <optional>

#include <fmt/format.h>

#include "cpgmatch/errors.hpp"

namespace cpgmatch::dds {

void validate_domain(int domain, const std::string& what) {
  if (domain < 0 || domain > kMaxDomainId) {
    throw InputError(fmt::format("{}: domain id {} is outside 0..{}", what, domain, kMaxDomainId));
  }
}

namespace {

// The domain id in environment variable `name`, or nothing when it is unset or empty.
std::optional<int> domain_from_env(const char* name) {
  const char* text = std::getenv(name);
  if (text == nullptr || *text == '\0') return std::nullopt;
  char* end = nullptr;
  errno = 0;
  const long value = std::strtol(text, &end, 10);
  if (*end != '\0' || errno == ERANGE) throw InputError(fmt::format("{}: '{}' is not a domain id", name, text));
  if (value < 0 || value > kMaxDomainId) {
    throw InputError(fmt::format("{}: domain id {} is outside 0..{}", name, text, kMaxDomainId));
  }
  return static_cast<int>(value);
}

}  // namespace

int default_domain() {
  // cpgmatch's own variable first: it is the more specific wish where a ROS 2 shell sets both.
  if (const auto domain = domain_from_env("CPGMATCH_DOMAIN")) return *domain;
  if (const auto domain = domain_from_env("ROS_DOMAIN_ID")) return *domain;
  return 0;
}

}  // namespace cpgmatch::dds
