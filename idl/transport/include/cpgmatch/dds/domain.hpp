// DDS domain ids: `--domain D` on every executable, defaulting to $CPGMATCH_DOMAIN, else ROS 2's
// $ROS_DOMAIN_ID, else 0.
#pragma once

#include <string>

namespace cpgmatch::dds {

// The RTPS port mapping (7400 + 250 * domain + ...) leaves room for domains 0..232.
inline constexpr int kMaxDomainId = 232;

// $CPGMATCH_DOMAIN if set, else $ROS_DOMAIN_ID if set, else 0; InputError naming the variable whose value
// is not a domain id (a bad $ROS_DOMAIN_ID counts even though $CPGMATCH_DOMAIN is unset, as ROS 2 refuses it).
int default_domain();

// InputError naming `what` unless 0 <= domain <= kMaxDomainId.
void validate_domain(int domain, const std::string& what = "--domain");

}  // namespace cpgmatch::dds
