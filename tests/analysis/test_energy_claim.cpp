// The energy claim and the good-gait statistic on synthetic studies whose answers are known.
#include <cmath>

#include <gtest/gtest.h>

#include "cpgmatch/analysis/energy_claim.hpp"
#include "cpgmatch/analysis/replicates.hpp"
#include "cpgmatch/analysis/science_report.hpp"
#include "cpgmatch/analysis/statistics.hpp"

namespace cpgmatch::analysis {
namespace {

Trial gait(int id, double cost, double feedback, double speed) {
  Trial t;
  t.trial_id = id;
  t.ok = true;
  t.cost = cost;
  t.terms = {feedback, 1.0 / (10.0 * speed), 0.5, 0.01, 0.0};
  t.mean_speed_mps = speed;
  t.normalized_torque = 2.0 / speed;
  t.summed_torque_nm = 2.0;
  return t;
}

const MeasureStats& measure(const ScienceReport& r, const std::string& key) {
  for (const auto& m : r.measures) {
    if (m.key == key) return m;
  }
  throw std::runtime_error("no measure " + key);
}

// 40 rollouts; J_feedback rises with the index, speed swings independently of it (a pattern of four
// levels), and the electrical cost of transport is (1 + J_feedback) / speed: it falls with matching only
// once speed is accounted for. Positive work per metre is (2 - J_feedback) / speed: the opposite sign.
StudyTrials speed_confounded_study() {
  StudyTrials s;
  s.initial_points = 15;
  const double speeds[] = {0.15, 0.4, 0.25, 0.3};
  for (int i = 0; i < 40; ++i) {
    const double fb = 0.02 * (i + 1), v = speeds[(i * 3) % 4];
    Trial t = gait(i, 3.0, fb, v);
    t.energy.electrical_cost_of_transport = (1.0 + fb) / v;
    t.energy.positive_work_j_per_m = (2.0 - fb) / v;
    s.trials.push_back(t);
  }
  return s;
}

TEST(EnergyClaim, AtEqualSpeedTheSignOfMatchingShowsThroughASpeedThatScramblesTheRawRho) {
  const ScienceReport r = science_report(speed_confounded_study());
  const MeasureStats& cot = measure(r, "electrical_cost_of_transport");
  EXPECT_EQ(cot.samples, 40);
  EXPECT_LT(std::abs(cot.rho_feedback), 0.5);  // speed's swings dominate the raw ranks
  EXPECT_GT(cot.rho_feedback_residual, 0.95);
  EXPECT_GT(cot.rho_feedback_partial, 0.9);
  EXPECT_NEAR(cot.speed_exponent, -1.0, 0.05);
  const MeasureStats& work = measure(r, "positive_work_per_m");
  EXPECT_LT(work.rho_feedback_residual, -0.95);  // the test can say "no": work rises as feedback falls
  EXPECT_LT(work.rho_feedback_partial, -0.9);
  // A measure the study has no data for is NaN, never a number that could pass for a result.
  EXPECT_EQ(measure(r, "signed_torque_per_speed").samples, 0);
  EXPECT_TRUE(std::isnan(measure(r, "signed_torque_per_speed").rho_feedback));
}

TEST(EnergyClaim, LearningRatioIsTheLateMedianOverTheInitialDesignsAndIgnoresFalls) {
  StudyTrials s;
  s.initial_points = 3;
  const double cot[] = {4.0, 6.0, 5.0, 9.0, 3.0, 2.0, 1.0};  // rollouts 1-3 initial, 5-7 late (last 3)
  for (int i = 0; i < 7; ++i) {
    Trial t = gait(i, 3.0, 0.1, 0.3);
    t.energy.electrical_cost_of_transport = cot[i];
    s.trials.push_back(t);
  }
  s.trials[3].fell = true;
  Trial fallen = gait(7, 20.0, 0.1, 0.3);
  fallen.fell = true;
  fallen.energy.electrical_cost_of_transport = 100.0;  // a fall's numbers must not count
  s.trials.push_back(fallen);
  ReportOptions o;
  o.last_rollouts = 4;  // rollouts 5-8
  const MeasureStats& m = measure(science_report(s, o), "electrical_cost_of_transport");
  EXPECT_DOUBLE_EQ(m.initial_median, 5.0);
  EXPECT_DOUBLE_EQ(m.late_median, 2.0);
  EXPECT_DOUBLE_EQ(m.ratio, 0.4);
}

TEST(GoodGaits, TheBestQuartileHasSmallContactAndPeriodicityWhileTheBadGaitsPoolTheFractionDown) {
  // 16 non-fallen rollouts plus falls. The four cheapest (costs 1-4) are clean; of the twelve others only
  // two are. J_feedback + J_distance = 0.1 + 1 / (10 x 0.3) = 0.433, so "small" means < 0.0433.
  StudyTrials s;
  for (int i = 0; i < 16; ++i) {
    Trial t = gait(i, 16.0 - i, 0.1, 0.3);  // rollout 16 is the cheapest
    const bool clean = i >= 12 || i == 0 || i == 1;
    t.terms.contact = clean ? 0.01 : 0.3;
    t.terms.periodicity = clean ? 0.0 : (i % 2 ? 0.5 : 0.01);  // bad contact, half of them bad periodicity
    s.trials.push_back(t);
  }
  Trial fall = gait(16, 0.5, 0.1, 0.3);  // a fall is never a good gait, whatever its cost
  fall.fell = true;
  s.trials.push_back(fall);
  const ScienceReport r = science_report(s);
  EXPECT_EQ(r.small_terms_best_quartile.rollouts, 4);
  EXPECT_DOUBLE_EQ(r.small_terms_best_quartile.both, 1.0);
  EXPECT_DOUBLE_EQ(r.small_terms_best_quartile.contact, 1.0);
  EXPECT_DOUBLE_EQ(r.fraction_both_small, 6.0 / 16);
  EXPECT_DOUBLE_EQ(r.fraction_contact_small, 6.0 / 16);
  EXPECT_DOUBLE_EQ(r.fraction_periodicity_small, 11.0 / 16);  // 6 clean + 5 of the 10 bad with i even
  const auto j = to_json(r);
  EXPECT_DOUBLE_EQ(j["small_terms"]["best_quartile"]["both"].get<double>(), 1.0);
  EXPECT_EQ(j["small_terms"]["best_quartile"]["rollouts"], 4);
  // A quarter rounds up: 5 rollouts give a best quartile of 2.
  s.trials.resize(5);
  EXPECT_EQ(science_report(s).small_terms_best_quartile.rollouts, 2);
}

TEST(EnergyClaim, KneeSteadyShareAndTheSentenceThatSaysWhatDominatesEqOne) {
  StudyTrials s;
  for (int i = 0; i < 3; ++i) {
    Trial t = gait(i, 3.0, 0.1, 0.3);
    t.summed_torque_nm = 4.0;
    t.energy.knee = PerLeg<JointEnergy>(4);  // a quadruped's four knees
    for (auto& knee : t.energy.knee) knee.signed_mean_torque_nm = -0.25 * (i + 1);  // steady shares 0.25, 0.5, 0.75
    s.trials.push_back(t);
  }
  EXPECT_DOUBLE_EQ(knee_steady_share_median(s), 0.5);
  EXPECT_NE(eq1_sentence(0.5).find("50%"), std::string::npos);
  EXPECT_NE(eq1_sentence(std::nan("")).find("no energy data"), std::string::npos);
}

TEST(Statistics, SignTestCountsSidesAndGivesTheBinomialP) {
  const SignTest t = sign_test({0.1, 0.2, -0.1, 0.3, 0.0, std::nan("")}, 0.0);
  EXPECT_EQ(t.above, 3);
  EXPECT_EQ(t.below, 1);
  EXPECT_DOUBLE_EQ(t.p_two_sided, 2.0 * 5.0 / 16.0);  // P(X <= 1) for n = 4, doubled
  const SignTest all = sign_test(std::vector<double>(10, 0.5), 1.0);
  EXPECT_EQ(all.below, 10);
  EXPECT_DOUBLE_EQ(all.p_two_sided, 2.0 / 1024.0);
  EXPECT_DOUBLE_EQ(sign_test({}, 0.0).p_two_sided, 1.0);
}

TEST(Statistics, PartialSpearmanRemovesACommonDriver) {
  // x and y both follow z with small swaps of their own that disagree: rho(x, y) = 16/21 through z alone;
  // given z (rho 19/21 and 20/21 with it) what is left is anti-correlated:
  // (16/21 - 19/21 x 20/21) / sqrt((1 - (19/21)^2) (1 - (20/21)^2)) = -44 / sqrt(3280).
  const std::vector<double> z = {1, 2, 3, 4, 5, 6, 7, 8};
  const std::vector<double> x = {2, 1, 4, 3, 6, 5, 8, 7};
  const std::vector<double> y = {1, 3, 2, 4, 5, 7, 6, 8};
  EXPECT_NEAR(spearman(x, y), 16.0 / 21, 1e-12);
  EXPECT_NEAR(partial_spearman(x, y, z), -44.0 / std::sqrt(3280.0), 1e-12);
  EXPECT_TRUE(std::isnan(partial_spearman(z, y, z)));  // x ranks exactly like z: nothing is left
}

TEST(Replicates, RhosAndRatiosGetASignTestOverSeeds) {
  std::vector<nlohmann::json> reports;
  for (const double rho : {0.3, 0.2, -0.1, 0.4}) {
    reports.push_back({{"measures", {{"electrical_cost_of_transport", {{"rho_feedback_partial", rho}, {"ratio", 0.8}}}}},
                       {"learning", {{"feedback_ratio", 0.5}}},
                       {"rollouts", 150}});
  }
  const ReplicateSummary s = aggregate_replicates(reports);
  const auto& rho = s.stats.at("measures.electrical_cost_of_transport.rho_feedback_partial");
  ASSERT_TRUE(rho.sign_reference.has_value());
  EXPECT_EQ(*rho.sign_reference, 0.0);
  EXPECT_EQ(rho.sign.above, 3);
  EXPECT_EQ(rho.sign.below, 1);
  const auto& ratio = s.stats.at("measures.electrical_cost_of_transport.ratio");
  EXPECT_EQ(*ratio.sign_reference, 1.0);
  EXPECT_EQ(ratio.sign.below, 4);
  EXPECT_EQ(s.stats.at("learning.feedback_ratio").sign.below, 4);
  EXPECT_FALSE(s.stats.at("rollouts").sign_reference.has_value());
  const auto j = to_json(s);
  EXPECT_EQ(j["statistics"]["measures.electrical_cost_of_transport.rho_feedback_partial"]["sign_test"]["above"], 3);
}

}  // namespace
}  // namespace cpgmatch::analysis
