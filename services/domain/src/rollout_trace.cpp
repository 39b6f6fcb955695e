#include "cpgmatch/domain/rollout_trace.hpp"

#include <algorithm>

namespace cpgmatch::domain {

MeasuredTick to_measured_tick(const TraceSample& sample) {
  MeasuredTick tick;
  tick.time_s = sample.time_s;
  tick.pitch_rad = sample.state->trunk.pitch_rad;
  tick.vx_mps = sample.state->trunk.vx_mps;
  tick.legs = PerLeg<MeasuredLeg>(sample.state->legs.size());
  for (std::size_t leg = 0; leg < tick.legs.size(); ++leg) {
    const JointCommand& cmd = sample.output->commands[leg];
    const LegState& ls = sample.state->legs[leg];
    tick.legs[leg] = {cmd.hip_angle_rad, ls.hip_angle_rad, cmd.knee_flexion_rad, ls.knee_flexion_rad,
                      (*sample.contacts)[leg], ls.foot_normal_force_n};
  }
  return tick;
}

TraceSink record_trace(MeasuredTrace& trace) {
  return [&trace](const TraceSample& s) { trace.ticks.push_back(to_measured_tick(s)); };
}

TraceSink record_trace_bounded(MeasuredTrace& trace, std::size_t max_ticks, std::uint64_t& dropped) {
  trace.ticks.clear();
  trace.ticks.reserve(max_ticks);
  dropped = 0;
  return [&trace, &dropped, max_ticks](const TraceSample& s) {
    if (trace.ticks.size() < max_ticks) {
      trace.ticks.push_back(to_measured_tick(s));  // within the reserved room: no allocation
    } else {
      ++dropped;
    }
  };
}

std::vector<RolloutTraceChunk> split_trace(const RolloutTrace& trace, std::size_t chunk_ticks) {
  chunk_ticks = std::max<std::size_t>(chunk_ticks, 1);
  const std::size_t total = trace.trace.ticks.size();
  const std::size_t count = std::max<std::size_t>(1, (total + chunk_ticks - 1) / chunk_ticks);
  std::vector<RolloutTraceChunk> chunks(count);
  for (std::size_t i = 0; i < count; ++i) {
    RolloutTraceChunk& c = chunks[i];
    c.id = trace.id;
    c.worker_id = trace.worker_id;
    c.chunk_index = static_cast<std::uint32_t>(i);
    c.chunk_count = static_cast<std::uint32_t>(count);
    c.total_ticks = static_cast<std::uint32_t>(total);
    c.first_tick = static_cast<std::uint32_t>(i * chunk_ticks);
    c.control_rate_hz = trace.control_rate_hz;
    c.terrain = trace.terrain;
    c.seed = trace.seed;
    c.parameters = trace.parameters;
    c.ticks_dropped = trace.ticks_dropped;
    const auto first = trace.trace.ticks.begin() + static_cast<std::ptrdiff_t>(std::min(total, i * chunk_ticks));
    const auto last = trace.trace.ticks.begin() + static_cast<std::ptrdiff_t>(std::min(total, (i + 1) * chunk_ticks));
    c.ticks.assign(first, last);
  }
  return chunks;
}

}  // namespace cpgmatch::domain
