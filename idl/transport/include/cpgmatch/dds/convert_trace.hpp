// A rollout trace chunk (domain/rollout_trace.hpp) to and from the wire (msg::RolloutTraceChunk). Kept apart
// from convert.hpp: one message, one file. from_wire refuses what the domain type cannot hold (ids past
// INT_MAX, a parameter named twice) with WireError; whether the chunk makes sense (sizes, finite values,
// the control grid) is the domain's TraceAssembler's to judge.
#pragma once

#include "cpgmatch/dds/convert.hpp"
#include "cpgmatch/domain/rollout_trace.hpp"

namespace cpgmatch::dds {

msg::RolloutTraceChunk to_wire(const domain::RolloutTraceChunk& chunk);
domain::RolloutTraceChunk from_wire(const msg::RolloutTraceChunk& chunk);

}  // namespace cpgmatch::dds
