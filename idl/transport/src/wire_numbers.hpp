// How numbers cross between the domain (int ids and counts) and the wire (uint32): one rule for every
// converter in idl/transport (convert.cpp, convert_trace.cpp, ros2_convert.cpp). Internal to the transport.
#pragma once

#include <cstdint>

#include "cpgmatch/domain/rollout_report.hpp"

namespace cpgmatch::dds::wire {

// An id or count onto the wire; a negative value (none in a valid domain value) goes out as 0.
inline std::uint32_t u32(int v) { return v < 0 ? 0u : static_cast<std::uint32_t>(v); }

// A count from the wire as the domain's int: a value past INT_MAX (no real count) is held at INT_MAX.
int clamped(std::uint32_t v);

// Ids from the wire: a value past INT_MAX is not one this service ever issued, and is refused (WireError
// naming the field) rather than wrapped into a negative id.
domain::AttemptId attempt_id(std::uint64_t store_id, std::uint32_t study_id, std::uint32_t trial_id,
                             std::uint32_t attempt);

}  // namespace cpgmatch::dds::wire
