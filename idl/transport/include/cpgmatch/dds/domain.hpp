// DDS domain ids: `--domain D` on every executable, defaulting to $CPGMATCH_DOMAIN, else 0.
#pragma once

#include <string>

namespace cpgmatch::dds {

// The RTPS port mapping (7400 + 250 * domain + ...) leaves room for domains 0..232.
inline constexpr int kMaxDomainId = 232;

// $CPGMATCH_DOMAIN if set (InputError naming the variable when it is not an id), else 0.
int default_domain();

// InputError naming `what` unless 0 <= domain <= kMaxDomainId.
void validate_domain(int domain, const std::string& what = "--domain");

}  // namespace cpgmatch::dds
