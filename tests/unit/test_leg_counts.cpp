// The CPG, its feedback and the cost for robots with 2, 4 and 6 legs: gaits are data (one phase offset per
// leg) and leg groups decide girdle partners and duty factors.
#include <cmath>

#include <gtest/gtest.h>

#include "cpgmatch/controller.hpp"
#include "cpgmatch/cost.hpp"
#include "cpgmatch/cpg.hpp"
#include "cpgmatch/errors.hpp"

namespace cpgmatch {
namespace {

LegLayout hexapod() {
  return {{"L1", "R1", "L2", "R2", "L3", "R3"}, {0, 0, 1, 1, 2, 2}, {"front", "middle", "hind"}};
}
LegLayout biped() { return {{"L", "R"}, {0, 0}, {"all"}}; }

Gait gait(const char* name, std::initializer_list<double> offsets) { return {name, PerLeg<double>(offsets)}; }

// Two tripods half a cycle apart: L1 R2 L3 against R1 L2 R3.
Gait tripod() { return gait("tripod", {0.0, 0.5, 0.5, 0.0, 0.0, 0.5}); }
// A wave gait: one leg at a time, back to front on each side.
Gait wave() { return gait("wave", {0.5, 0.0, 0.333333333333, 0.833333333333, 0.166666666667, 0.666666666667}); }

TEST(LegCounts, EveryGaitLocksFromAnyStartFor2And6Legs) {
  struct Case {
    Gait gait;
    PerLeg<double> start;
  };
  const std::vector<Case> cases{
      {tripod(), {0.13, 0.71, 0.42, 0.95, 0.3, 0.05}},
      {wave(), {0.9, 0.1, 0.45, 0.2, 0.61, 0.33}},
      {gait("alternate", {0.0, 0.5}), {0.1, 0.2}},
      {gait("hop", {0.0, 0.0}), {0.1, 0.55}},  // not 0.5 apart: the unstable fixed point of the coupling
  };
  for (const Case& c : cases) {
    PhaseOscillatorNetwork net(c.gait, 0.5);
    net.reset(c.start);
    const double initial = net.locking_error();
    const PerLeg<double> free(c.gait.leg_count(), 1.0);
    for (int i = 0; i < 10000; ++i) net.step(0.002, 1.0, free);  // 20 s at 500 Hz
    EXPECT_GT(initial, 0.1) << c.gait.name;
    EXPECT_LT(net.locking_error(), 1e-3) << c.gait.name;
  }
}

TEST(LegCounts, APhaseVectorOfTheWrongLengthIsRefused) {
  PhaseOscillatorNetwork net(tripod(), 0.5);
  EXPECT_THROW(net.reset(PerLeg<double>{0.1, 0.2, 0.3, 0.4}), std::invalid_argument);
  ControllerConfig config;
  config.legs = hexapod();
  config.gaits = {gait("trot", {0.0, 0.5, 0.5, 0.0})};  // four offsets for six legs
  config.gait = "trot";
  EXPECT_THROW(resolve_gait(config), InputError);
  config.gait = "gallop";
  EXPECT_THROW(resolve_gait(config), InputError);
}

TEST(LegCounts, GirdlesAreTheGroupsOfTwoLegs) {
  const LegLayout h = hexapod();
  EXPECT_EQ(h.girdle_partner(0), 1);
  EXPECT_EQ(h.girdle_partner(3), 2);
  EXPECT_EQ(h.girdle_partner(5), 4);
  EXPECT_EQ(biped().girdle_partner(1), 0);
  const LegLayout three_in_a_row{{"a", "b", "c"}, {0, 0, 0}, {"all"}};
  EXPECT_FALSE(three_in_a_row.girdle_partner(1).has_value());
  EXPECT_TRUE(h.uses_hind_duty_factor(4));
  EXPECT_FALSE(h.uses_hind_duty_factor(2));  // the middle group takes the front legs' duty factor
}

TEST(LegCounts, PitchRepeatsTwicePerCycleWhenEveryGroupAlternates) {
  EXPECT_EQ(pitch_harmonic(tripod(), hexapod()), 2);
  EXPECT_EQ(pitch_harmonic(gait("pronk6", {0, 0, 0, 0, 0, 0}), hexapod()), 1);
  EXPECT_EQ(pitch_harmonic(gait("alternate", {0.0, 0.5}), biped()), 2);
  EXPECT_EQ(pitch_harmonic(gait("hop", {0.0, 0.0}), biped()), 1);
}

// A hexapod's controller runs its six legs: each stance starts at its gait offset and lasts its group's
// duty factor; a leg whose ground is missing holds its phase back (late touchdown) while the others walk on.
TEST(LegCounts, ASixLeggedControllerSchedulesEachLegAndItsFeedback) {
  ControllerConfig config;
  config.legs = hexapod();
  config.gaits = {tripod()};
  config.gait = "tripod";
  config.startup_ramp_s = 0.0;
  CpgParameters p;
  p.duty_factor_front = 0.6;
  p.duty_factor_hind = 0.4;
  CpgController ctrl(p, config);
  ASSERT_EQ(ctrl.leg_count(), 6u);
  PerLeg<int> stance(6, 0);
  int ticks = 0;
  int late_touchdown_ticks = 0;
  for (; ticks < 2500; ++ticks) {  // 5 s
    PerLeg<bool> contacts(6);
    for (std::size_t leg = 0; leg < 6; ++leg) {
      contacts[leg] = ctrl.network().phases()[leg] < step_timing(p, config.legs, static_cast<int>(leg)).duty_factor;
    }
    contacts[2] = false;  // L2 never finds the ground
    const ControllerOutput out = ctrl.update(contacts);
    ASSERT_EQ(out.commands.size(), 6u);
    for (std::size_t leg = 0; leg < 6; ++leg) stance[leg] += out.phases[leg] < step_timing(p, config.legs, static_cast<int>(leg)).duty_factor;
    late_touchdown_ticks += out.activity[2].late_touchdown;
  }
  EXPECT_NEAR(stance[0] / double(ticks), 0.6, 0.03);  // front group
  EXPECT_NEAR(stance[4] / double(ticks), 0.4, 0.03);  // hind group
  EXPECT_NEAR(stance[3] / double(ticks), 0.6, 0.03);  // middle group: the front legs' duty factor
  EXPECT_GT(late_touchdown_ticks, 100);               // L2's missing ground is measured
  EXPECT_LT(stance[2] / double(ticks), stance[3] / double(ticks) + 0.1);
}

TEST(LegCounts, TheCostAveragesOverTheRobotsLegs) {
  CostRecorder rec(CostConfig{});
  for (int i = 0; i <= 5000; ++i) {
    CostSample s;
    s.time_s = i / 500.0;
    s.x_m = 0.3 * s.time_s;
    s.contact = PerLeg<bool>(6, std::fmod(s.time_s, 1.0) < 0.5);
    s.activity = PerLeg<FeedbackActivity>(6);
    s.activity[0].late_touchdown = true;  // one leg of six, all the time
    s.abs_hip_torque_nm = s.abs_knee_torque_nm = PerLeg<double>(6, 1.0);
    rec.add(s);
  }
  const CostBreakdown b = rec.evaluate(1.0, 2.0);
  EXPECT_NEAR(b.feedback_fraction.late_touchdown, 1.0 / 6.0, 1e-9);
  EXPECT_NEAR(b.summed_torque_nm, 12.0, 1e-9);  // six hips and six knees at 1 N m
  EXPECT_NEAR(b.terms.contact, 0.0, 0.01);      // two clean contact changes per step and leg
}

}  // namespace
}  // namespace cpgmatch
