// Who a worker is: its id, the fixed-size key the workers topic is keyed by, and which authenticated identity
// may speak for it.
#pragma once

#include <cstdint>
#include <string>

namespace cpgmatch::domain {

// 64-bit FNV-1a of the worker id: the fixed-size key of the workers topic.
std::uint64_t worker_key(const std::string& worker_id);

// With DDS-Security a worker id belongs to the identity whose certificate has common name (CN) `common_name`:
// it is that CN, or the CN, '/' and a suffix (several worker processes of one identity: node12/1, node12/2).
// The optimizer counts a report, or takes an announcement, only from a sender whose certificate owns the
// worker id in it; an empty CN owns nothing. The same rule names a study's robot (`robot: morti` is served
// by morti and morti/left).
bool worker_id_belongs_to(const std::string& worker_id, const std::string& common_name);

}  // namespace cpgmatch::domain
