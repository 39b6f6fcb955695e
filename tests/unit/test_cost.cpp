// Cost terms on analytic inputs.
#include <cmath>

#include <gtest/gtest.h>

#include "cpgmatch/cost.hpp"
#include "../support/morti_legs.hpp"

namespace cpgmatch {
namespace {

std::vector<double> sine(double freq, double amp, double rate, double seconds, double offset = 0.0) {
  std::vector<double> v;
  for (int i = 0; i < static_cast<int>(rate * seconds); ++i) v.push_back(offset + amp * std::sin(2 * M_PI * freq * i / rate));
  return v;
}

TEST(Cost, PureSinePitchAtTheCpgFrequencyHasZeroPeriodicityCost) {
  EXPECT_NEAR(periodicity_term(sine(1.0, 0.1, 500, 10), 500, 1.0), 0.0, 0.01);
}

TEST(Cost, PureSinePitchAtAnotherFrequencyCostsTheFrequencyDifference) {
  EXPECT_NEAR(periodicity_term(sine(1.7, 0.1, 500, 10), 500, 1.0), 0.7, 0.01);
  EXPECT_NEAR(dominant_frequency_hz(sine(2.35, 0.2, 500, 10), 500), 2.35, 0.01);
}

TEST(Cost, PitchTermIsMeanMaxMinusMeanMinPerStride) {
  // amplitude 0.1 rad around an offset: max - min = 0.2 rad per stride, whatever the offset.
  EXPECT_NEAR(pitch_range_term(sine(1.0, 0.1, 500, 10, 0.3), 500, 1.0), 0.2, 1e-3);
}

TEST(Cost, CleanStepsHaveNoContactCostAndAStumblePerStepCostsOne) {
  const double rate = 500, f = 1.0;
  std::vector<PerLeg<bool>> clean, stumbling;
  for (int i = 0; i < 5000; ++i) {
    const double phi = std::fmod(i / rate * f, 1.0);
    const bool c = phi < 0.5;
    clean.push_back({c, c, c, c});
    const bool s = c && !(phi > 0.2 && phi < 0.25);  // one extra flight phase inside each stance
    stumbling.push_back({s, s, s, s});
  }
  EXPECT_NEAR(contact_term(clean, rate, f), 0.0, 1e-3);
  // A 10-step window holds 19 transitions of a clean gait, not 20, so the estimate is 19/20.
  EXPECT_NEAR(contact_term(stumbling, rate, f), 1.0, 0.06);
}

TEST(Cost, RecorderCombinesTermsWithWeightsAndNormalisesTorqueBySpeed) {
  CostConfig cfg;
  cfg.weights.pitch = 2.0;
  CostRecorder rec(cfg);
  for (int i = 0; i <= 5000; ++i) {
    CostSample s;
    s.activity = PerLeg<FeedbackActivity>(test::kNumLegs);
    s.abs_hip_torque_nm = s.abs_knee_torque_nm = PerLeg<double>(test::kNumLegs, 0.0);
    s.time_s = i / 500.0;
    s.x_m = 0.3 * s.time_s;  // 0.3 m/s
    s.pitch_rad = 0.05 * std::sin(2 * M_PI * s.time_s);
    const bool c = std::fmod(s.time_s, 1.0) < 0.5;
    s.contact = {c, !c, !c, c};
    s.activity[0].late_touchdown = std::fmod(s.time_s, 1.0) < 0.1;  // 10 % of the time on one leg
    s.abs_hip_torque_nm = {1, 1, 1, 1};
    s.abs_knee_torque_nm = {0.5, 0.5, 0.5, 0.5};
    rec.add(s);
  }
  const CostBreakdown b = rec.evaluate(1.0, 1.0);
  EXPECT_NEAR(b.distance_m, 3.0, 1e-9);
  EXPECT_NEAR(b.terms.distance, 1.0 / 3.0, 1e-9);
  EXPECT_NEAR(b.feedback_fraction.late_touchdown, 0.025, 1e-3);  // 10 % / 4 legs
  EXPECT_NEAR(b.terms.feedback, 0.025, 1e-3);
  EXPECT_NEAR(b.terms.pitch, 0.1, 1e-3);
  EXPECT_NEAR(b.normalized_torque, 6.0 / 0.3, 1e-6);  // 4 x (1 + 0.5) N m at 0.3 m/s
  EXPECT_NEAR(b.cost, b.terms.feedback + b.terms.distance + 2 * b.terms.pitch + b.terms.contact + b.terms.periodicity, 1e-12);
}

TEST(Cost, StandingStillIsExpensiveButFinite) {
  CostRecorder rec({});
  for (int i = 0; i <= 1000; ++i) rec.add(CostSample{i / 500.0, -0.01, 0.0, {}, {}, {}, {}});
  const CostBreakdown b = rec.evaluate(1.0, 2.0);
  EXPECT_TRUE(std::isfinite(b.cost));
  EXPECT_NEAR(b.terms.distance, 1.0 / CostConfig{}.min_distance_m, 1e-9);
}

TEST(Cost, EarlierFallsCostMore) {
  CostRecorder rec({});
  EXPECT_GT(rec.fall_cost(2.0, 20.0, 2.0), rec.fall_cost(15.0, 20.0, 2.0));
}

// The worst rollout that does not fall: standing still (J_distance at its cap), every feedback mechanism
// active all the time, the largest pitch range short of a fall, chattering contacts and a pitch spectrum far
// from the gait's. Even this costs less than the mildest fall (one at the very end of the rollout).
TEST(Cost, AFallAlwaysCostsMoreThanTheWorstRolloutThatDidNotFall) {
  CostConfig cfg;
  CostRecorder rec(cfg);
  for (int i = 0; i <= 5000; ++i) {
    CostSample s;
    s.activity = PerLeg<FeedbackActivity>(test::kNumLegs);
    s.abs_hip_torque_nm = s.abs_knee_torque_nm = PerLeg<double>(test::kNumLegs, 0.0);
    s.time_s = i / 500.0;
    s.x_m = 0.0;
    s.pitch_rad = 0.79 * std::sin(2 * M_PI * 37.0 * s.time_s);  // near the fall limit, at 37 Hz
    const bool c = i % 2 == 0;                                  // contact flips every sample
    s.contact = {c, c, c, c};
    for (auto& a : s.activity) a = {true, true, true, true};
    rec.add(s);
  }
  const double expected_pitch_hz = 2.0;
  const CostBreakdown worst = rec.evaluate(1.0, expected_pitch_hz);
  EXPECT_GT(worst.terms.distance, 3.9);
  EXPECT_GT(worst.terms.contact, 1.9);
  EXPECT_LE(worst.cost, cfg.non_fall_bound(expected_pitch_hz));
  EXPECT_GT(rec.fall_cost(20.0, 20.0, expected_pitch_hz), worst.cost);
}

TEST(Cost, CleanTrotPitchAtTwiceTheStepFrequencyScoresZeroPeriodicity) {
  // A symmetric trot loads front and hind twice per cycle: pitch at 2 f plus a weaker f component from
  // a small left/right asymmetry. Compared with the gait's expected 2 f, not with f.
  std::vector<double> pitch = sine(2.0, 0.05, 500, 10);
  const std::vector<double> asym = sine(1.0, 0.01, 500, 10);
  for (std::size_t i = 0; i < pitch.size(); ++i) pitch[i] += asym[i];
  EXPECT_NEAR(periodicity_term(pitch, 500, 2.0), 0.0, 0.02);
  EXPECT_NEAR(periodicity_term(pitch, 500, 1.0), 1.0, 0.02);  // the paper's literal f_cpg would charge 1 Hz
}

}  // namespace
}  // namespace cpgmatch
