// A rollout trace chunk to the wire and back (convert_trace.hpp): every value of every tick survives to the
// bit, and what the domain cannot hold (an id past INT_MAX, a parameter named twice) is refused by name.
#include <gtest/gtest.h>

#include <cmath>

#include "cpgmatch/dds/convert_trace.hpp"
#include "../support/morti_legs.hpp"

using namespace cpgmatch::test;  // Morti's legs: FL FR HL HR

namespace cpgmatch::dds {
namespace {

domain::RolloutTraceChunk chunk_of(std::size_t ticks) {
  domain::RolloutTraceChunk c;
  c.id = {0x1234567890abcdefull, 3, 17, 2};
  c.worker_id = "morti";
  c.chunk_index = 1;
  c.chunk_count = 2;
  c.total_ticks = static_cast<std::uint32_t>(256 + ticks);
  c.first_tick = 256;
  c.control_rate_hz = 500.0;
  c.terrain = "rough:0.02";
  c.seed = 0xffffffffffffffffull;
  c.ticks_dropped = 12;
  c.parameters = to_map(CpgParameters{});
  for (std::size_t i = 0; i < ticks; ++i) {
    domain::MeasuredTick t;
    t.legs = PerLeg<domain::MeasuredLeg>(4);
    t.time_s = (256 + i) / 500.0;
    t.pitch_rad = std::sin(0.3 * i);
    t.vx_mps = 1.0 / (i + 3.0);
    for (int leg = 0; leg < kNumLegs; ++leg) {
      t.legs[leg] = {0.1 * leg + i, -0.2 * leg - i, std::cos(i + leg), std::exp(-0.01 * i) + leg, (i * leg) % 2 == 1,
                     3.3 * leg + i};
    }
    c.ticks.push_back(t);
  }
  return c;
}

TEST(TraceWire, EveryValueSurvivesTheRoundTrip) {
  const domain::RolloutTraceChunk in = chunk_of(256);
  const domain::RolloutTraceChunk out = from_wire(to_wire(in));
  EXPECT_EQ(out.id.store_id, in.id.store_id);
  EXPECT_EQ(out.id.study_id, 3);
  EXPECT_EQ(out.id.trial_id, 17);
  EXPECT_EQ(out.id.attempt, 2);
  EXPECT_EQ(out.worker_id, "morti");
  EXPECT_EQ(out.chunk_index, 1u);
  EXPECT_EQ(out.chunk_count, 2u);
  EXPECT_EQ(out.total_ticks, in.total_ticks);
  EXPECT_EQ(out.first_tick, 256u);
  EXPECT_EQ(out.terrain, "rough:0.02");
  EXPECT_EQ(out.seed, in.seed);
  EXPECT_EQ(out.ticks_dropped, 12u);
  EXPECT_EQ(out.parameters, in.parameters);
  ASSERT_EQ(out.ticks.size(), in.ticks.size());
  for (std::size_t i = 0; i < in.ticks.size(); ++i) {
    EXPECT_EQ(out.ticks[i].time_s, in.ticks[i].time_s);
    EXPECT_EQ(out.ticks[i].pitch_rad, in.ticks[i].pitch_rad);
    EXPECT_EQ(out.ticks[i].vx_mps, in.ticks[i].vx_mps);
    for (int leg = 0; leg < kNumLegs; ++leg) {
      const auto &a = in.ticks[i].legs[leg], &b = out.ticks[i].legs[leg];
      EXPECT_EQ(b.hip_target_rad, a.hip_target_rad);
      EXPECT_EQ(b.hip_rad, a.hip_rad);
      EXPECT_EQ(b.knee_target_rad, a.knee_target_rad);
      EXPECT_EQ(b.knee_rad, a.knee_rad);
      EXPECT_EQ(b.contact, a.contact);
      EXPECT_EQ(b.foot_force_n, a.foot_force_n);
    }
  }
}

// A hexapod's trace (issue 31): a tick carries its legs as a sequence, any count from 1 to 8.
TEST(TraceWire, ATickCarriesAnyNumberOfLegs) {
  for (const std::size_t legs : {std::size_t{1}, std::size_t{6}, kMaxLegs}) {
    domain::RolloutTraceChunk in = chunk_of(3);
    for (auto& t : in.ticks) {
      t.legs = PerLeg<domain::MeasuredLeg>(legs);
      for (std::size_t leg = 0; leg < legs; ++leg) t.legs[leg] = {0.1 * leg, -0.2 * leg, 0.3, 0.4 + leg, leg % 2 == 0, 5.0 * leg};
    }
    const domain::RolloutTraceChunk out = from_wire(to_wire(in));
    ASSERT_EQ(out.ticks.size(), 3u);
    for (std::size_t i = 0; i < 3; ++i) {
      ASSERT_EQ(out.ticks[i].legs.size(), legs);
      for (std::size_t leg = 0; leg < legs; ++leg) {
        EXPECT_EQ(out.ticks[i].legs[leg].knee_rad, in.ticks[i].legs[leg].knee_rad);
        EXPECT_EQ(out.ticks[i].legs[leg].contact, in.ticks[i].legs[leg].contact);
        EXPECT_EQ(out.ticks[i].legs[leg].foot_force_n, in.ticks[i].legs[leg].foot_force_n);
      }
    }
  }
}

TEST(TraceWire, RefusesWhatTheDomainCannotHold) {
  msg::RolloutTraceChunk w = to_wire(chunk_of(2));
  w.trial_id(0x80000000u);
  EXPECT_THROW(from_wire(w), WireError);
  w = to_wire(chunk_of(2));
  w.parameters().push_back(w.parameters().front());
  EXPECT_THROW(from_wire(w), WireError);
}

}  // namespace
}  // namespace cpgmatch::dds
