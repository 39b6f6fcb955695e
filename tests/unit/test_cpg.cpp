// Phase locking, trajectory shapes and stance fraction of the CPG.
#include <algorithm>
#include <cmath>

#include <set>
#include <string>

#include <gtest/gtest.h>

#include "cpgmatch/seeds.hpp"

#include "cpgmatch/controller.hpp"
#include "cpgmatch/cpg.hpp"
#include "cpgmatch/errors.hpp"
#include "../support/morti_legs.hpp"

using namespace cpgmatch::test;  // Morti's legs: FL FR HL HR

namespace cpgmatch {
namespace {

TEST(Cpg, PhaseLockingConvergesToEveryGaitsPhaseDifferences) {
  for (const auto& name : Gait::names()) {
    PhaseOscillatorNetwork net(Gait::named(name), 0.5);
    net.reset({0.13, 0.71, 0.42, 0.95});  // far from every gait
    const double initial = net.locking_error();
    PerLeg<double> free{1, 1, 1, 1};
    for (int i = 0; i < 5000; ++i) net.step(0.002, 1.0, free);  // 10 s at 500 Hz
    EXPECT_GT(initial, 0.1) << name;
    EXPECT_LT(net.locking_error(), 1e-3) << name;
  }
}

TEST(Cpg, FreeRunningPhaseAdvancesAtTheStepFrequency) {
  PhaseOscillatorNetwork net(Gait::named("trot"), 0.5);
  PerLeg<double> free{1, 1, 1, 1};
  for (int i = 0; i < 2500; ++i) net.step(0.002, 1.5, free);  // 5 s at 1.5 Hz -> 7.5 cycles
  EXPECT_EQ(net.cycles()[0], 7);
  EXPECT_NEAR(net.phases()[0], 0.5, 1e-6);
}

TEST(Cpg, ADeceleratedLegFallsOutOfLockAndTheCouplingPullsItBackAfterwards) {
  PhaseOscillatorNetwork net(Gait::named("trot"), 0.5);
  for (int i = 0; i < 50; ++i) net.step(0.002, 1.0, {0.1, 1, 1, 1});
  EXPECT_GT(net.locking_error(), 0.02);
  for (int i = 0; i < 5000; ++i) net.step(0.002, 1.0, {1, 1, 1, 1});
  EXPECT_LT(net.locking_error(), 1e-3);
}

TEST(Cpg, AHeldLegIsStillPulledByItsCouplingSoItsLagStaysBoundedAndTheOthersSlowDown) {
  // Feedback scales a node's own frequency; the coupling terms stay. A leg held at rate 0 for 2 s (a
  // foot that never finds the ground) therefore lags by a bounded amount and drags the network with it,
  // instead of drifting two cycles out of the gait while the others walk on.
  PhaseOscillatorNetwork net(Gait::named("trot"), 0.5);
  const long other_cycles_before = net.cycles()[kFrontRight];
  const double other_phase_before = net.phases()[kFrontRight];
  double worst_lock = 0.0;
  for (int i = 0; i < 1000; ++i) {
    net.step(0.002, 1.0, {0.0, 1, 1, 1});
    worst_lock = std::max(worst_lock, net.locking_error());
  }
  EXPECT_GT(worst_lock, 0.02);  // the held leg does fall behind...
  EXPECT_LT(worst_lock, 0.15);  // ...by less than a sixth of a cycle
  const double other_advance =
      (net.cycles()[kFrontRight] - other_cycles_before) + net.phases()[kFrontRight] - other_phase_before;
  EXPECT_LT(other_advance, 1.9);  // the others walked slower than 1 Hz while it was held
  EXPECT_GT(net.phases()[kFrontLeft] + net.cycles()[kFrontLeft], 0.5);  // and the held leg was pulled along
}

TEST(Cpg, AHeldLegThatIsAheadWaitsInsteadOfRunningBackwards) {
  // FL starts 0.1 cycle ahead of its place in the trot and is held (rate 0): the coupling pulls it back
  // (velocity K * sum sin < 0), but a phase only waits; it never decreases and never wraps backwards.
  PhaseOscillatorNetwork net(Gait::named("trot"), 2.0);
  net.reset({0.1, 0.5, 0.5, 0.0});
  double previous = net.phases()[kFrontLeft];
  for (int i = 0; i < 200; ++i) {
    net.step(0.002, 1.0, {0.0, 1, 1, 1});
    EXPECT_GE(net.phases()[kFrontLeft], previous) << "step " << i;
    previous = net.phases()[kFrontLeft];
  }
  EXPECT_EQ(net.cycles()[kFrontLeft], 0);
}

TEST(Cpg, UnknownGaitIsAnInputError) { EXPECT_THROW(Gait::named("gallop"), InputError); }

TEST(Trajectory, HipProfileHitsItsKeyPointsAndIsContinuous) {
  const double D = 0.4, os = 0.2;
  EXPECT_NEAR(hip_profile(0.0, D, os), 1.0, 1e-12);         // touchdown: front
  EXPECT_NEAR(hip_profile(D, D, os), -1.0, 1e-12);          // toe-off: back
  const double peak = D + (1 - D) * (1 - os);
  EXPECT_NEAR(hip_profile(peak, D, os), 1.0 + os, 1e-12);   // overswing peak before retraction
  EXPECT_NEAR(hip_profile(0.999999, D, os), 1.0, 1e-5);     // retracted back to +1 at touchdown
  for (double phi = 0.0; phi < 1.0; phi += 1e-4) {
    EXPECT_LT(std::abs(hip_profile(phi + 1e-4, D, os) - hip_profile(phi, D, os)), 0.01) << phi;
  }
}

TEST(Trajectory, StanceFractionEqualsTheDutyFactor) {
  // With the controller running free (contacts as scheduled), the fraction of time each leg's hip moves
  // backwards (stance) equals its duty factor.
  CpgParameters p;
  p.duty_factor_front = 0.35;
  p.duty_factor_hind = 0.6;
  p.overswing = 0.0;
  ControllerConfig cfg;
  cfg.startup_ramp_s = 0.0;
  cfg.feedback = FeedbackConfig::none();
  CpgController ctrl(p, cfg);
  PerLeg<int> stance(test::kNumLegs, 0), total(test::kNumLegs, 0);
  PerLeg<double> last(test::kNumLegs);
  bool first = true;
  for (int i = 0; i < 5000; ++i) {
    PerLeg<bool> scheduled(test::kNumLegs);
    for (int leg = 0; leg < kNumLegs; ++leg) scheduled[leg] = ctrl.network().phases()[leg] < step_timing(p, test::morti_legs(), leg).duty_factor;
    const auto out = ctrl.update(scheduled);
    for (int leg = 0; leg < kNumLegs; ++leg) {
      if (!first) {
        stance[leg] += out.commands[leg].hip_angle_rad < last[leg];
        ++total[leg];
      }
      last[leg] = out.commands[leg].hip_angle_rad;
    }
    first = false;
  }
  for (int leg = 0; leg < kNumLegs; ++leg) {
    const double expected = is_front(leg) ? 0.35 : 0.6;
    EXPECT_NEAR(static_cast<double>(stance[leg]) / total[leg], expected, 0.01) << kLegNames[leg];
  }
}

// FL's largest extra knee flexion (the early-touchdown reflex) over 4 s: its foot meets the ground again at
// phase 0.7-0.75 of every swing, with FR's foot forced down or up meanwhile; every other contact follows
// the schedule. Only early touchdown acts, so no phase differs between the runs.
double front_left_reflex_flexion(const std::string& gait, bool partner_down_while_fl_stumbles) {
  CpgParameters p;
  ControllerConfig cfg;
  cfg.gait = gait;
  cfg.startup_ramp_s = 0.0;
  cfg.feedback.late_touchdown = false;
  cfg.feedback.early_toeoff = false;
  ControllerConfig open_loop = cfg;
  open_loop.feedback = FeedbackConfig::none();
  CpgController with_reflex(p, cfg), without(p, open_loop);
  double largest = 0.0;
  for (int i = 0; i < 2000; ++i) {
    PerLeg<bool> contacts(test::kNumLegs);
    for (int leg = 0; leg < kNumLegs; ++leg) {
      contacts[leg] = with_reflex.network().phases()[leg] < step_timing(p, test::morti_legs(), leg).duty_factor;
    }
    const double fl = with_reflex.network().phases()[kFrontLeft];
    const bool stumbling = fl >= 0.7 && fl < 0.75;
    if (stumbling) {
      contacts[kFrontLeft] = true;
      contacts[kFrontRight] = partner_down_while_fl_stumbles;
    }
    const double extra = with_reflex.update(contacts).commands[kFrontLeft].knee_flexion_rad -
                         without.update(contacts).commands[kFrontLeft].knee_flexion_rad;
    largest = std::max(largest, extra);
  }
  return largest;
}

TEST(Controller, TheReflexWaitsForTheGirdlesOtherLegWhereTheGaitAlternatesItsLegsNotInABound) {
  const double reflex = FeedbackConfig{}.reflex_knee_flexion_rad;
  // Trot: FR is meant to carry the front while FL swings. Down, the reflex fires; up, it is withheld.
  EXPECT_NEAR(front_left_reflex_flexion("trot", true), reflex, 0.02);
  EXPECT_NEAR(front_left_reflex_flexion("trot", false), 0.0, 1e-9);
  // Bound: FL and FR swing together, so FR off the ground says nothing; the reflex fires.
  EXPECT_NEAR(front_left_reflex_flexion("bound", false), reflex, 0.02);
}

TEST(Trajectory, KneeFlexesOnlyInItsWindow) {
  CpgParameters p;
  const StepTiming t = step_timing(p, test::morti_legs(), kFrontLeft);
  EXPECT_EQ(knee_profile(t.knee_flex_start - 0.01, t.knee_flex_start, t.retraction_start), 0.0);
  EXPECT_EQ(knee_profile(t.retraction_start + 0.01, t.knee_flex_start, t.retraction_start), 0.0);
  EXPECT_NEAR(knee_profile(0.5 * (t.knee_flex_start + t.retraction_start), t.knee_flex_start, t.retraction_start), 1.0, 1e-12);
}

TEST(Parameters, BadValuesAreRejectedByName) {
  CpgParameters p;
  EXPECT_THROW(set_parameter(p, "duty_factor_front", 0.95), InputError);
  EXPECT_THROW(set_parameter(p, "duty_factor_front", std::nan("")), InputError);
  EXPECT_THROW(set_parameter(p, "hip_ofset", 0.1), InputError);
  EXPECT_THROW(apply_assignment(p, "overswing=abc"), InputError);
  try {
    apply_assignment(p, "overswing=0.9");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("overswing"), std::string::npos);
  }
  apply_assignment(p, "overswing=0.3");
  EXPECT_EQ(p.overswing, 0.3);
}

TEST(Cpg, BodyPitchRepeatsTwicePerCycleInGaitsWhoseGirdlesAlternateLeftRight) {
  EXPECT_EQ(pitch_harmonic(Gait::named("trot"), test::morti_legs()), 2);
  EXPECT_EQ(pitch_harmonic(Gait::named("pace"), test::morti_legs()), 2);
  EXPECT_EQ(pitch_harmonic(Gait::named("walk"), test::morti_legs()), 2);
  EXPECT_EQ(pitch_harmonic(Gait::named("bound"), test::morti_legs()), 1);
  EXPECT_EQ(pitch_harmonic(Gait::named("pronk"), test::morti_legs()), 1);
}

TEST(Seeds, EveryTrialGetsItsOwnRolloutSeedAndTheSameOneOnEveryRun) {
  std::set<std::uint64_t> seen;
  for (std::uint64_t trial = 0; trial < 1000; ++trial) seen.insert(derived_seed(7, trial));
  EXPECT_EQ(seen.size(), 1000u);
  EXPECT_EQ(derived_seed(7, 3), derived_seed(7, 3));
  EXPECT_NE(derived_seed(7, 3), derived_seed(8, 3));
}

}  // namespace
}  // namespace cpgmatch
