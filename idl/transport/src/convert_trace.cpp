#include "cpgmatch/dds/convert_trace.hpp"

#include <limits>

#include <fmt/format.h>

#include "wire_numbers.hpp"

namespace cpgmatch::dds {
namespace {

msg::TraceTick tick_to_wire(const domain::MeasuredTick& t) {
  msg::TraceTick w;
  w.time_s(t.time_s);
  w.pitch_rad(t.pitch_rad);
  w.vx_mps(t.vx_mps);
  if (t.legs.size() > kMaxLegs) {
    throw WireError(fmt::format("a trace tick of {} legs: a tick carries 1 to {}", t.legs.size(), kMaxLegs));
  }
  for (const domain::MeasuredLeg& l : t.legs) {
    msg::TraceLeg leg;
    leg.hip_target_rad(l.hip_target_rad);
    leg.hip_rad(l.hip_rad);
    leg.knee_target_rad(l.knee_target_rad);
    leg.knee_rad(l.knee_rad);
    leg.contact(l.contact);
    leg.foot_force_n(l.foot_force_n);
    w.legs().push_back(leg);
  }
  return w;
}

domain::MeasuredTick tick_from_wire(const msg::TraceTick& w) {
  domain::MeasuredTick t;
  t.time_s = w.time_s();
  t.pitch_rad = w.pitch_rad();
  t.vx_mps = w.vx_mps();
  t.legs = PerLeg<domain::MeasuredLeg>(w.legs().size());
  for (std::size_t leg = 0; leg < t.legs.size(); ++leg) {
    const msg::TraceLeg& l = w.legs()[leg];
    t.legs[leg] = {l.hip_target_rad(), l.hip_rad(), l.knee_target_rad(), l.knee_rad(), l.contact(), l.foot_force_n()};
  }
  return t;
}

}  // namespace

msg::RolloutTraceChunk to_wire(const domain::RolloutTraceChunk& c) {
  msg::RolloutTraceChunk w;
  w.store_id(c.id.store_id);
  w.study_id(wire::u32(c.id.study_id));
  w.trial_id(wire::u32(c.id.trial_id));
  w.attempt(wire::u32(c.id.attempt));
  w.worker_id(c.worker_id);
  w.chunk_index(c.chunk_index);
  w.chunk_count(c.chunk_count);
  w.total_ticks(c.total_ticks);
  w.first_tick(c.first_tick);
  w.control_rate_hz(c.control_rate_hz);
  w.terrain(c.terrain);
  w.seed(c.seed);
  w.ticks_dropped(c.ticks_dropped);
  w.parameters(to_wire(c.parameters));
  w.ticks().reserve(c.ticks.size());
  for (const auto& t : c.ticks) w.ticks().push_back(tick_to_wire(t));
  return w;
}

domain::RolloutTraceChunk from_wire(const msg::RolloutTraceChunk& w) {
  domain::RolloutTraceChunk c;
  c.id = wire::attempt_id(w.store_id(), w.study_id(), w.trial_id(), w.attempt());
  c.worker_id = w.worker_id().to_string();
  c.chunk_index = w.chunk_index();
  c.chunk_count = w.chunk_count();
  c.total_ticks = w.total_ticks();
  c.first_tick = w.first_tick();
  c.control_rate_hz = w.control_rate_hz();
  c.terrain = w.terrain().to_string();
  c.seed = w.seed();
  c.ticks_dropped = w.ticks_dropped();
  c.parameters = from_wire(w.parameters());
  c.ticks.reserve(w.ticks().size());
  for (const auto& t : w.ticks()) c.ticks.push_back(tick_from_wire(t));
  return c;
}

}  // namespace cpgmatch::dds
