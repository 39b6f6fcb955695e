// Each feedback mechanism fires on its synthetic contact sequence, and only then.
#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <tuple>
#include <utility>

#include <gtest/gtest.h>

#include "cpgmatch/feedback.hpp"
#include "../support/morti_legs.hpp"

using namespace cpgmatch::test;  // Morti's legs: FL FR HL HR

namespace cpgmatch {
namespace {

// Drives one leg's feedback through two cycles at 1 Hz (500 Hz ticks) with contact given as a
// function of phase, and counts the ticks each mechanism was active in the second cycle.
struct Counts {
  int ltd = 0, etd = 0, eto = 0, lto = 0;
  double min_rate = 1.0;
  bool hip_passive = false;
};

// D 0.5, knee flex 0.4, retraction 0.9.
StepTiming test_timing() {
  CpgParameters p;
  p.duty_factor_front = 0.5;
  p.knee_phase_shift = 0.2;
  p.overswing = 0.2;
  return step_timing(p, test::morti_legs(), kFrontLeft);
}

Counts run(const std::function<bool(double)>& contact_at, FeedbackConfig cfg = {}) {
  const StepTiming t = test_timing();
  LegFeedback fb(cfg);
  Counts c;
  double phase = 0.0;
  for (int tick = 0; tick < 1500; ++tick) {
    const auto a = fb.update(phase, contact_at(phase), 0.002, t, true);
    if (tick >= 500) {
      c.ltd += a.activity.late_touchdown;
      c.etd += a.activity.early_touchdown;
      c.eto += a.activity.early_toeoff;
      c.lto += a.activity.late_toeoff;
      c.min_rate = std::min(c.min_rate, a.phase_rate);
      c.hip_passive = c.hip_passive || a.hip_passive;
    }
    phase += 0.002 * a.phase_rate;
    if (phase >= 1.0) phase -= 1.0;
  }
  return c;
}

TEST(Feedback, NominalContactPatternTriggersNothing) {
  const Counts c = run([](double phi) { return phi < 0.5; });
  EXPECT_EQ(c.ltd + c.etd + c.eto + c.lto, 0);
  EXPECT_EQ(c.min_rate, 1.0);
}

TEST(Feedback, LateTouchdownDeceleratesThePhaseUntilContact) {
  // Ground arrives only at phase 0.1 instead of 0: the leg waits.
  const Counts c = run([](double phi) { return phi >= 0.1 && phi < 0.5; });
  EXPECT_GT(c.ltd, 0);
  EXPECT_LT(c.min_rate, 1.0);
  EXPECT_EQ(c.etd + c.eto + c.lto, 0);
}

TEST(Feedback, LateTouchdownHoldsThePhaseOnlyForTheMaxWaitButKeepsMeasuring) {
  // The ground never comes in stance 0..0.3 (a foot hanging while the other legs carry the body).
  CpgParameters p;
  p.duty_factor_front = 0.5;
  const StepTiming t = step_timing(p, test::morti_legs(), kFrontLeft);
  FeedbackConfig cfg;
  cfg.late_touchdown_phase_rate = 0.1;
  cfg.late_touchdown_max_wait_s = 0.1;
  LegFeedback fb(cfg);
  double phase = 0.6;  // start in swing so that the next stance begins untouched
  double held_s = 0.0, measured_s = 0.0;
  bool in_second_stance = false;
  for (int tick = 0; tick < 1500; ++tick) {
    const bool contact = phase >= 0.3 && phase < 0.5;
    const auto a = fb.update(phase, contact, 0.002, t, true);
    if (phase < 0.3) in_second_stance = true;
    if (in_second_stance && phase < 0.3) {
      held_s += a.phase_rate < 1.0 ? 0.002 : 0.0;
      measured_s += a.activity.late_touchdown ? 0.002 : 0.0;
    }
    phase += 0.002 * a.phase_rate;
    if (phase >= 1.0) {
      phase -= 1.0;
      if (in_second_stance) break;  // one stance window measured
    }
  }
  // Held back for the wait only (one tick of slack), then free running: 0.3 cycles take 0.1 s held
  // (0.01 cycles) + 0.29 s free, all of it measured as late touchdown.
  EXPECT_NEAR(held_s, 0.1, 0.0021);
  EXPECT_GT(measured_s, 0.35);
}

TEST(Feedback, EarlyTouchdownTriggersTheKneeReflexWithAPassiveHip) {
  // Lifts off at 0.5 as planned, then hits the ground at 0.7, long before retraction (0.9).
  const Counts c = run([](double phi) { return phi < 0.5 || (phi >= 0.7 && phi < 0.75); });
  EXPECT_GT(c.etd, 0);
  EXPECT_TRUE(c.hip_passive);
  EXPECT_EQ(c.ltd + c.eto + c.lto, 0);
}

TEST(Feedback, TheReflexsHipIsPassiveForTheImpactOnlyThenDrivesWhileTheKneeIsStillUp) {
  // Same stumble (ground at phase 0.7 in swing). 500 Hz ticks: the reflex lasts 0.12 s (60 ticks), its hip
  // is passive for the first 0.04 s (20 ticks), and the knee is still pulled up after that.
  const StepTiming t = test_timing();
  auto passive_and_driven_ticks = [&](FeedbackConfig cfg) {
    LegFeedback fb(cfg);
    int passive = 0, driven_with_knee_up = 0;
    double phase = 0.0;
    for (int tick = 0; tick < 1000; ++tick) {
      const auto a = fb.update(phase, phase < 0.5 || (phase >= 0.7 && phase < 0.75), 0.002, t, true);
      passive += a.hip_passive;
      driven_with_knee_up += a.activity.early_touchdown && !a.hip_passive && a.extra_knee_flexion > 0.1;
      phase = std::fmod(phase + 0.002 * a.phase_rate, 1.0);
    }
    return std::pair{passive, driven_with_knee_up};
  };
  const FeedbackConfig shipped;
  ASSERT_DOUBLE_EQ(shipped.reflex_hip_passive_s, 0.04);
  const auto [passive, driven] = passive_and_driven_ticks(shipped);
  EXPECT_GE(passive, 2 * 20);  // two swings, 20 ticks each (21 if the timer's round-off lands just short)
  EXPECT_LE(passive, 2 * 21);
  EXPECT_GT(driven, 2 * 20);   // the rest of the reflex: hip driving, knee still > 0.1 rad up
  FeedbackConfig whole = shipped;
  whole.reflex_hip_passive_s = whole.reflex_duration_s;  // the reading before 2026-12-02
  EXPECT_GE(passive_and_driven_ticks(whole).first, 2 * 60);
  EXPECT_LE(passive_and_driven_ticks(whole).first, 2 * 61);
  FeedbackConfig never = shipped;
  never.reflex_hip_passive = false;
  EXPECT_EQ(passive_and_driven_ticks(never).first, 0);
}

TEST(Feedback, TheReflexIsWithheldButMeasuredWhileTheGirdlesOtherLegIsOffTheGround) {
  // The stumble of the tests above (ground at phase 0.7 in swing), with the girdle partner's contact given
  // as a function of phase: off the ground from 0.6 to 0.8 (it touches down late), or always down.
  const StepTiming t = test_timing();
  auto reflex = [&](const std::function<bool(double)>& partner_at, FeedbackConfig cfg) {
    LegFeedback fb(cfg);
    int measured = 0;
    double max_flexion = 0.0;
    bool hip_passive = false;
    double phase = 0.0;
    for (int tick = 0; tick < 1000; ++tick) {
      const bool contact = phase < 0.5 || (phase >= 0.7 && phase < 0.75);
      const auto a = fb.update(phase, contact, 0.002, t, partner_at(phase));
      measured += a.activity.early_touchdown;
      max_flexion = std::max(max_flexion, a.extra_knee_flexion);
      hip_passive = hip_passive || a.hip_passive;
      phase = std::fmod(phase + 0.002 * a.phase_rate, 1.0);
    }
    return std::tuple{measured, max_flexion, hip_passive};
  };
  const auto partner_late = [](double phi) { return phi < 0.6 || phi >= 0.8; };
  const auto partner_down = [](double) { return true; };
  const FeedbackConfig shipped;
  ASSERT_TRUE(shipped.reflex_needs_girdle_support);

  const auto [measured_alone, flexion_alone, passive_alone] = reflex(partner_late, shipped);
  EXPECT_GE(measured_alone, 2 * 60);  // two swings of a 0.12-s reflex: measured in full
  EXPECT_EQ(flexion_alone, 0.0);      // ... but the knee is not pulled up
  EXPECT_FALSE(passive_alone);        // ... and the hip keeps holding

  const auto [measured_carried, flexion_carried, passive_carried] = reflex(partner_down, shipped);
  EXPECT_EQ(measured_carried, measured_alone);
  EXPECT_NEAR(flexion_carried, shipped.reflex_knee_flexion_rad, 0.01);
  EXPECT_TRUE(passive_carried);

  FeedbackConfig ungated = shipped;  // the reflex before 2026-12-02
  ungated.reflex_needs_girdle_support = false;
  EXPECT_NEAR(std::get<1>(reflex(partner_late, ungated)), shipped.reflex_knee_flexion_rad, 0.01);
}

TEST(Feedback, AReflexWithheldInOneSwingFiresInTheNextWhenTheGirdleIsCarriedAndStaysWithheldIfThePartnerLands) {
  // The stumble at phase 0.7 in every swing. Cycle 0: the partner is up from 0.6 to 0.72, so it lands
  // 0.02 cycles into the withheld reflex, which must stay withheld. Cycle 1: the partner is down; it fires.
  const StepTiming t = test_timing();
  LegFeedback fb{FeedbackConfig{}};
  double phase = 0.0;
  int cycle = 0;
  std::array<double, 2> largest{0.0, 0.0};
  std::array<int, 2> measured{0, 0};
  for (int tick = 0; tick < 1000; ++tick) {
    const bool contact = phase < 0.5 || (phase >= 0.7 && phase < 0.75);
    const bool partner = cycle == 1 || phase < 0.6 || phase >= 0.72;
    const auto a = fb.update(phase, contact, 0.002, t, partner);
    largest[cycle] = std::max(largest[cycle], a.extra_knee_flexion);
    measured[cycle] += a.activity.early_touchdown;
    const double next = phase + 0.002 * a.phase_rate;
    if (next >= 1.0) ++cycle;
    phase = std::fmod(next, 1.0);
    if (cycle > 1) break;
  }
  EXPECT_EQ(largest[0], 0.0);
  EXPECT_GE(measured[0], 60);
  EXPECT_NEAR(largest[1], FeedbackConfig{}.reflex_knee_flexion_rad, 0.01);
  EXPECT_GE(measured[1], 60);
}

TEST(Feedback, EarlyToeoffStartsKneeFlexionEarly) {
  // Contact lost at 0.3 (after mid-stance, 0.25), before the knee was due to flex at 0.4.
  const StepTiming t = test_timing();
  LegFeedback fb;
  double phase = 0.0, flex_start = -1.0;
  int eto = 0;
  for (int tick = 0; tick < 1000; ++tick) {
    const bool contact = phase < 0.3 || phase >= 0.999;
    const auto a = fb.update(phase, contact, 0.002, t, true);
    if (tick >= 500 && a.activity.early_toeoff) {
      ++eto;
      flex_start = a.knee_flex_start;
    }
    EXPECT_FALSE(a.activity.late_touchdown || a.activity.early_touchdown || a.activity.late_toeoff);
    phase += 0.002 * a.phase_rate;
    if (phase >= 1.0) phase -= 1.0;
  }
  EXPECT_GT(eto, 0);
  EXPECT_NEAR(flex_start, 0.3, 0.01);
}

TEST(Feedback, EarlyToeoffIsCancelledWhenTheGroundComesBack) {
  // Contact flickers off at 0.3 for 6 ms and returns (a slip): the leg is loaded again, so the early
  // knee flexion must stop and the scheduled one (0.4) applies.
  const StepTiming t{0.5, 0.4, 0.9};
  LegFeedback fb;
  double phase = 0.0;
  int eto_after_return = 0, eto_during_gap = 0;
  for (int tick = 0; tick < 1000; ++tick) {
    const bool gap = phase >= 0.3 && phase < 0.306;
    const bool contact = phase < 0.5 && !gap;
    const auto a = fb.update(phase, contact, 0.002, t, true);
    if (tick >= 500) {
      eto_during_gap += gap && a.activity.early_toeoff;
      eto_after_return += phase > 0.32 && phase < 0.4 && a.activity.early_toeoff;
      if (phase > 0.32 && phase < 0.4) {
        EXPECT_LT(a.knee_flex_start, 0.0) << "early flexion still on at " << phase;
      }
    }
    phase += 0.002 * a.phase_rate;
    if (phase >= 1.0) phase -= 1.0;
  }
  EXPECT_GT(eto_during_gap, 0);
  EXPECT_EQ(eto_after_return, 0);
}

TEST(Feedback, AFootBouncingOffInTheFirstHalfOfStanceIsNoEarlyToeoff) {
  // D 0.5, knee flex due at 0.4, mid-stance at 0.25. The foot leaves the ground at 0.05 and is back at
  // 0.15 (a bounce after touchdown, the leg still in front of the hip taking the body's weight): no early
  // flexion at all. Session 7's window (eto_min_stance_fraction 0) flexed that loaded knee at 0.05.
  const StepTiming t{0.5, 0.4, 0.9};
  auto eto_ticks = [&](double min_stance_fraction, double* first_flex_start) {
    FeedbackConfig cfg;
    cfg.eto_min_stance_fraction = min_stance_fraction;
    LegFeedback fb(cfg);
    double phase = 0.0;
    int eto = 0;
    *first_flex_start = -1.0;
    for (int tick = 0; tick < 1000; ++tick) {
      const bool bounce = phase >= 0.05 && phase < 0.15;
      const auto a = fb.update(phase, phase < 0.5 && !bounce, 0.002, t, true);
      if (tick >= 500 && a.activity.early_toeoff) {
        ++eto;
        if (*first_flex_start < 0.0) *first_flex_start = a.knee_flex_start;
      }
      phase += 0.002 * a.phase_rate;
      if (phase >= 1.0) phase -= 1.0;
    }
    return eto;
  };
  double flex_start = 0.0;
  EXPECT_EQ(eto_ticks(0.5, &flex_start), 0);
  EXPECT_GT(eto_ticks(0.0, &flex_start), 0);
  EXPECT_NEAR(flex_start, 0.05, 0.01);
}

TEST(Feedback, AFootStillOffTheGroundAtMidStanceStartsTheKneeFlexionThere) {
  // Contact lost at 0.1 for the rest of stance: the leg is unloaded in the half where it should unload,
  // so the knee flexes early, from mid-stance (0.25) rather than from the loss of contact.
  const StepTiming t{0.5, 0.4, 0.9};
  LegFeedback fb;
  double phase = 0.0, first_flex_start = -1.0;
  for (int tick = 0; tick < 1000; ++tick) {
    const auto a = fb.update(phase, phase < 0.1 || phase >= 0.999, 0.002, t, true);
    if (tick >= 500 && a.activity.early_toeoff && first_flex_start < 0.0) first_flex_start = a.knee_flex_start;
    if (tick >= 500 && phase < 0.249) {
      EXPECT_FALSE(a.activity.early_toeoff) << "at phase " << phase;
    }
    phase += 0.002 * a.phase_rate;
    if (phase >= 1.0) phase -= 1.0;
  }
  EXPECT_NEAR(first_flex_start, 0.25, 0.005);
}

TEST(Feedback, AToeScuffingTheGroundJustAfterToeoffIsNoEarlyTouchdown) {
  // Lifts off at 0.5, touches again 10 ms later (0.51-0.53): a scuff, below etd_min_airborne_s (40 ms).
  const Counts scuff = run([](double phi) { return phi < 0.5 || (phi >= 0.51 && phi < 0.53); });
  EXPECT_EQ(scuff.etd, 0);
  EXPECT_FALSE(scuff.hip_passive);
  // The same contact after 100 ms of real flight is an early touchdown.
  const Counts impact = run([](double phi) { return phi < 0.5 || (phi >= 0.6 && phi < 0.62); });
  EXPECT_GT(impact.etd, 0);
}

TEST(Feedback, AFootLandingWithTheLegReExtendedIsATouchdownNotAnEarlyTouchdown) {
  // Knee flexion runs 0.4 -> 0.9 (peak at 0.65); it is below 20% of the amplitude again from ~0.83 on.
  // Landing at 0.86, 40 ms before the retraction, and staying down: on time, no reflex and no late touchdown.
  const Counts landing = run([](double phi) { return phi < 0.5 || phi >= 0.86; });
  EXPECT_EQ(landing.etd, 0);
  EXPECT_EQ(landing.ltd, 0);
  EXPECT_FALSE(landing.hip_passive);
  // Hitting the ground at 0.75 with the knee still ~65% flexed for clearance is a stumble: the reflex fires.
  const Counts stumble = run([](double phi) { return phi < 0.5 || phi >= 0.75; });
  EXPECT_GT(stumble.etd, 0);
  EXPECT_TRUE(stumble.hip_passive);
  // With the landing window switched off (fraction 0) the same landing at 0.86 fires the reflex.
  FeedbackConfig strict;
  strict.etd_min_knee_flexion_fraction = 0.0;
  EXPECT_GT(run([](double phi) { return phi < 0.5 || phi >= 0.86; }, strict).etd, 0);
}

TEST(Feedback, LateToeoffIsMeasuredAndDeceleratesOnlyWhenConfigured) {
  const auto late = [](double phi) { return phi < 0.6; };  // still on the ground after 0.5
  const Counts measured = run(late);
  EXPECT_GT(measured.lto, 0);
  EXPECT_EQ(measured.min_rate, 1.0);
  EXPECT_EQ(measured.ltd + measured.etd + measured.eto, 0);
  FeedbackConfig cfg;
  cfg.late_toeoff_deceleration = true;
  EXPECT_LT(run(late, cfg).min_rate, 1.0);
}

TEST(Feedback, DisabledMechanismsDoNotAct) {
  const Counts c = run([](double phi) { return phi >= 0.1 && phi < 0.5; }, FeedbackConfig::none());
  EXPECT_EQ(c.ltd, 0);
  EXPECT_EQ(c.min_rate, 1.0);
}

}  // namespace
}  // namespace cpgmatch
