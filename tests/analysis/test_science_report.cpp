// The science report on hand-made studies whose statistics can be worked out on paper.
#include <cmath>
#include <set>

#include <gtest/gtest.h>

#include "cpgmatch/analysis/jitter.hpp"
#include "cpgmatch/analysis/replicates.hpp"
#include "cpgmatch/analysis/science_report.hpp"
#include "cpgmatch/analysis/statistics.hpp"
#include "cpgmatch/seeds.hpp"

namespace cpgmatch::analysis {
namespace {

Trial walked(int id, double cost, double feedback, double torque, double speed) {
  Trial t;
  t.trial_id = id;
  t.ok = true;
  t.cost = cost;
  t.terms = {feedback, 1.0, 0.5, 0.01, 0.0};
  t.normalized_torque = torque;
  t.mean_speed_mps = speed;
  t.summed_torque_nm = torque * speed;
  t.params = {{"hip_offset", 0.1 * id}};
  return t;
}

Trial fallen(int id, double cost) {
  Trial t = walked(id, cost, 9.0, 99.0, 0.01);  // numbers a fall must never contribute
  t.fell = true;
  return t;
}

// 10 rollouts, 4 initial: rollouts 2 and 7 fall (1-based), rollout 9 is the best.
StudyTrials small_study() {
  StudyTrials s;
  s.name = "hand";
  s.initial_points = 4;
  s.trials = {walked(0, 5.0, 0.8, 4.0, 0.1), fallen(1, 8.0),  walked(2, 4.0, 0.6, 3.0, 0.2),
              walked(3, 4.5, 0.4, 2.0, 0.2), walked(4, 3.5, 0.3, 1.8, 0.25), walked(5, 3.2, 0.2, 1.5, 0.3),
              fallen(6, 7.0),                walked(7, 3.0, 0.15, 1.2, 0.3), walked(8, 2.5, 0.1, 1.0, 0.35),
              walked(9, 2.8, 0.12, 1.1, 0.3)};
  return s;
}

TEST(ScienceReport, FallsSplitAtTheInitialDesign) {
  const ScienceReport r = science_report(small_study());
  EXPECT_EQ(r.rollouts, 10);
  EXPECT_EQ(r.falls, 2);
  EXPECT_EQ(r.falls_initial, 1);  // rollout 2
  EXPECT_EQ(r.falls_after, 1);    // rollout 7
}

TEST(ScienceReport, FallsAfterTheDesignAreLocatedAtTheBoundsOrNextToTheBest) {
  // Two parameters, a in [0, 1] and b in [0, 2]; 2 initial rollouts. In the unit cube: best so far is
  // (0.4, 0.5) until rollout 4 (0.45, 0.55) beats it.
  auto at = [](Trial t, double a, double b) {
    t.params = {{"a", a}, {"b", b}, {"frequency", 1.0}};  // a fixed parameter has no bounds: ignored
    return t;
  };
  StudyTrials s;
  s.initial_points = 2;
  s.bounds = {{"a", {0.0, 1.0}}, {"b", {0.0, 2.0}}};
  Trial broken = walked(3, 0.1, 0.1, 1.0, 0.3);
  broken.ok = false;  // did not run: neither a fall nor a walk, and never the best
  s.trials = {at(walked(0, 1.0, 0.1, 1.0, 0.3), 0.5, 1.0), at(walked(1, 0.8, 0.1, 1.0, 0.3), 0.4, 1.0),
              at(fallen(2, 9.0), 1.0, 2.0),                at(broken, 0.4, 1.0),
              at(walked(4, 0.7, 0.1, 1.0, 0.3), 0.45, 1.1), at(fallen(5, 9.0), 0.5, 1.1),
              at(walked(6, 0.9, 0.1, 1.0, 0.3), 0.0, 1.0)};
  const FallLocations f = science_report(s).falls_after_locations;
  EXPECT_EQ(f.falls, 2);
  EXPECT_EQ(f.walked, 2);                                // rollouts 5 and 7; the initial two are not counted
  EXPECT_DOUBLE_EQ(f.falls_params_at_bound_median, 1.0);  // the corner (2) and the one next to the best (0)
  EXPECT_DOUBLE_EQ(f.walked_params_at_bound_median, 0.5);
  EXPECT_NEAR(f.falls_distance_to_best_median, 0.5 * (std::hypot(0.6, 0.5) + 0.05), 1e-12);
  EXPECT_NEAR(f.walked_distance_to_best_median, 0.5 * (std::hypot(0.05, 0.05) + std::hypot(0.45, 0.05)), 1e-12);
  EXPECT_EQ(f.falls_near_best, 1);
  const nlohmann::json j = to_json(science_report(s));
  EXPECT_EQ(j["falls"]["after_locations"]["falls_near_best"], 1);
  EXPECT_EQ(j["falls"]["after_locations"]["falls"], 2);

  // A rollout without a finite cost is never the best so far; an empty study has no medians.
  s.trials[1].cost = std::nan("");
  EXPECT_NEAR(science_report(s).falls_after_locations.falls_distance_to_best_median,
              0.5 * (std::hypot(0.5, 0.5) + 0.05), 1e-12);  // the corner fall measured from rollout 1 (0.5, 0.5)
  const FallLocations none = science_report(StudyTrials{}).falls_after_locations;
  EXPECT_EQ(none.falls + none.walked, 0);
  EXPECT_TRUE(std::isnan(none.falls_distance_to_best_median));
}

TEST(ScienceReport, WindowsAreClippedAndUseNonFallenRolloutsOnly) {
  ReportOptions o;
  o.windows = {{1, 4}, {5, 8}, {9, 150}, {200, 300}};
  const ScienceReport r = science_report(small_study(), o);
  ASSERT_EQ(r.windows.size(), 3u);  // the window beyond the study is dropped
  const WindowStats& w1 = r.windows[0];
  EXPECT_EQ(w1.rollouts, 4);
  EXPECT_EQ(w1.falls, 1);
  EXPECT_EQ(w1.walked, 3);
  EXPECT_DOUBLE_EQ(w1.feedback_mean, (0.8 + 0.6 + 0.4) / 3);
  EXPECT_DOUBLE_EQ(w1.feedback_median, 0.6);
  EXPECT_DOUBLE_EQ(w1.normalized_torque_median, 3.0);
  EXPECT_DOUBLE_EQ(w1.summed_torque_median_nm, 0.4);  // 0.4, 0.6, 0.4
  EXPECT_DOUBLE_EQ(w1.speed_mean_mps, 0.5 / 3);
  const WindowStats& w2 = r.windows[1];  // rollouts 5-8, rollout 7 fell
  EXPECT_EQ(w2.falls, 1);
  EXPECT_DOUBLE_EQ(w2.feedback_median, 0.2);  // 0.3, 0.2, 0.15
  EXPECT_DOUBLE_EQ(w2.normalized_torque_median, 1.5);
  const WindowStats& w3 = r.windows[2];
  EXPECT_EQ(w3.window.last, 10);
  EXPECT_EQ(w3.rollouts, 2);
  EXPECT_DOUBLE_EQ(w3.normalized_torque_median, 1.05);  // even count: mean of the middle two
}

TEST(ScienceReport, LearningRatiosCompareLastRolloutsWithTheInitialDesign) {
  ReportOptions o;
  o.last_rollouts = 4;  // rollouts 7..10; 7 fell
  const ScienceReport r = science_report(small_study(), o);
  EXPECT_EQ(r.late_first_rollout, 7);
  EXPECT_DOUBLE_EQ(r.feedback_initial_mean, 0.6);
  EXPECT_NEAR(r.feedback_late_mean, (0.15 + 0.1 + 0.12) / 3, 1e-12);
  EXPECT_NEAR(r.feedback_ratio, (0.37 / 3) / 0.6, 1e-12);
  EXPECT_DOUBLE_EQ(r.torque_initial_median, 3.0);
  EXPECT_DOUBLE_EQ(r.torque_late_median, 1.1);
  EXPECT_NEAR(r.torque_ratio, 1.1 / 3.0, 1e-12);
}

TEST(ScienceReport, BestAndWorst) {
  const ScienceReport r = science_report(small_study());
  EXPECT_EQ(r.best_rollout, 9);
  EXPECT_DOUBLE_EQ(r.best_cost, 2.5);
  EXPECT_DOUBLE_EQ(r.best_terms.feedback, 0.1);
  EXPECT_DOUBLE_EQ(r.best_speed_mps, 0.35);
  EXPECT_DOUBLE_EQ(r.best_params.at("hip_offset"), 0.8);
  EXPECT_EQ(r.worst_rollout, 2);
  EXPECT_DOUBLE_EQ(r.worst_cost, 8.0);
}

TEST(ScienceReport, FailedEvaluationsAreNeitherFallsNorCosts) {
  StudyTrials s = small_study();
  s.trials[0].ok = false;
  const ScienceReport r = science_report(s);
  EXPECT_EQ(r.failed_evaluations, 1);
  EXPECT_EQ(r.falls, 2);
  EXPECT_EQ(r.windows[0].rollouts, 10);  // the default 1-15 window, clipped to the study
  EXPECT_EQ(r.windows[0].walked, 7);     // 10 - 2 falls - 1 failed
  EXPECT_EQ(r.worst_rollout, 2);
  EXPECT_NEAR(r.cost_mean, (43.5 - 5.0) / 9, 1e-12);  // the failed rollout's cost is not a cost
}

TEST(ScienceReport, SmallTermFractions) {
  StudyTrials s = small_study();
  s.trials[2].terms.contact = 0.5;      // > 0.1 x (0.6 + 1.0)
  s.trials[3].terms.periodicity = 0.2;  // > 0.1 x (0.4 + 1.0)
  const ScienceReport r = science_report(s);
  EXPECT_DOUBLE_EQ(r.fraction_contact_small, 7.0 / 8);
  EXPECT_DOUBLE_EQ(r.fraction_periodicity_small, 7.0 / 8);
  EXPECT_DOUBLE_EQ(r.fraction_both_small, 6.0 / 8);
}

TEST(ScienceReport, FeedbackFallsWithTorqueInTheHandStudy) {
  const ScienceReport r = science_report(small_study());
  EXPECT_EQ(r.correlation_samples, 8);
  EXPECT_GT(r.rho_feedback_torque, 0.9);
}

TEST(ScienceReport, ResidualRemovesAnExactOneOverSpeedDependence) {
  // torque = exp(0.1 J) / speed with log(speed) orthogonal to J: the raw correlation is scrambled by
  // speed, the residual of log torque on log speed is exactly 0.1 (J - mean J), so its rho is 1.
  StudyTrials s;
  const double pattern[] = {1, -1, -1, 1, 1, -1, -1, 1};
  for (int i = 0; i < 8; ++i) {
    const double j = i + 1, speed = std::exp(1.5 * pattern[i]);
    s.trials.push_back(walked(i, 3.0, j, std::exp(0.1 * j) / speed, speed));
  }
  const ScienceReport r = science_report(s);
  EXPECT_LT(r.rho_feedback_torque, 0.5);
  EXPECT_NEAR(r.torque_speed_exponent, -1.0, 1e-9);
  EXPECT_NEAR(r.rho_feedback_torque_residual, 1.0, 1e-12);
}

TEST(ScienceReport, JsonCarriesWindowsAndThePaper) {
  const auto j = to_json(science_report(small_study()));
  ASSERT_TRUE(j["windows"].is_array());
  EXPECT_EQ(j["windows"][0]["first"], 1);
  EXPECT_EQ(j["falls"]["initial"], 1);
  EXPECT_EQ(j["paper"]["falls"]["total"], 16);
  EXPECT_DOUBLE_EQ(j["paper"]["best"]["cost"].get<double>(), 2.59);
  EXPECT_TRUE(j["jitter"].is_null());
  EXPECT_NE(format_table(science_report(small_study())).find("2.59"), std::string::npos);
}

TEST(ScienceReport, OldReportWithoutSummedTorqueFallsBackToTorqueTimesSpeed) {
  const nlohmann::json report = {{"ok", true}, {"fell", false}, {"cost", 3.0},
                                 {"terms", {{"feedback", 0.2}, {"distance", 1.0}, {"pitch", 0.1}, {"contact", 0.0}, {"periodicity", 0.0}}},
                                 {"normalized_torque", 2.0}, {"summed_torque_nm", nullptr}, {"mean_speed_mps", 0.25}};
  EXPECT_DOUBLE_EQ(trial_from_report(0, report, {}).summed_torque_nm, 0.5);
}

TEST(Spearman, MonotoneReversedAndTies) {
  const std::vector<double> x = {1, 2, 3, 4, 5};
  EXPECT_DOUBLE_EQ(spearman(x, {1, 4, 9, 16, 100}), 1.0);
  EXPECT_DOUBLE_EQ(spearman(x, {5, 4, 3, 2, 1}), -1.0);
  EXPECT_EQ(average_ranks({10, 20, 20, 30}), (std::vector<double>{1, 2.5, 2.5, 4}));
  // Ranks of y: 1, 2.5, 2.5, 4 against 1..4: r = 4.5 / sqrt(5 x 4.5) = 0.9486833
  EXPECT_NEAR(spearman({1, 2, 3, 4}, {10, 20, 20, 30}), 4.5 / std::sqrt(5.0 * 4.5), 1e-12);
  EXPECT_TRUE(std::isnan(spearman({1, 2, 3}, {7, 7, 7})));
}

TEST(Replicates, MeanAndSdOfEveryScalar) {
  const std::vector<nlohmann::json> reports = {
      {{"study_id", 1}, {"falls", {{"total", 10}}}, {"best", {{"cost", 2.0}}}, {"paper", {{"x", 1}}}},
      {{"study_id", 2}, {"falls", {{"total", 14}}}, {"best", {{"cost", nullptr}}}},
      {{"study_id", 3}, {"falls", {{"total", 18}}}, {"best", {{"cost", 4.0}}}}};
  const ReplicateSummary s = aggregate_replicates(reports);
  EXPECT_EQ(s.replicates, 3);
  EXPECT_DOUBLE_EQ(s.stats.at("falls.total").mean, 14.0);
  EXPECT_DOUBLE_EQ(s.stats.at("falls.total").sd, 4.0);
  EXPECT_EQ(s.stats.at("best.cost").n, 2);  // a null is not a zero
  EXPECT_DOUBLE_EQ(s.stats.at("best.cost").mean, 3.0);
  EXPECT_EQ(s.stats.count("study_id"), 0u);
  EXPECT_EQ(s.stats.count("paper.x"), 0u);
  EXPECT_DOUBLE_EQ(to_json(s)["statistics"]["falls.total"]["paper"].get<double>(), 16.0);
}

TEST(Jitter, PerturbsWithinOnePercentClampsAndCounts) {
  const std::map<std::string, double> best = {{"hip_offset", 0.35}, {"duty_factor_front", 0.5}, {"frequency", 1.0}};
  const std::map<std::string, Bounds> bounds = {{"hip_offset", {-0.35, 0.35}}, {"duty_factor_front", {0.3, 0.8}}};
  JitterOptions o;
  o.jitter_seed = 7;
  o.rollout_seed = 42;
  const auto points = jittered_points(best, bounds, o);
  ASSERT_EQ(points.size(), 12u);
  bool moved = false;
  for (const auto& p : points) {
    EXPECT_LE(p.at("hip_offset"), 0.35);  // clamped at the upper bound
    EXPECT_NEAR(p.at("duty_factor_front"), 0.5, 0.005 + 1e-15);
    moved |= p.at("duty_factor_front") != 0.5;
    EXPECT_EQ(p.at("frequency"), 1.0);  // fixed parameters are not perturbed
  }
  EXPECT_TRUE(moved);
  EXPECT_EQ(jittered_points(best, bounds, o), points);  // seeded
  int calls = 0;
  std::set<std::uint64_t> seeds;  // every draw its own rollout seed, derived from the study's
  const auto summary = jitter_best(best, bounds,
                                   [&](const std::map<std::string, double>& p, std::uint64_t seed) {
                                     EXPECT_EQ(seed, derived_seed(42, 1000000 + calls));
                                     seeds.insert(seed);
                                     ++calls;
                                     return RolloutOutcome{true, calls % 4 == 0, p.at("duty_factor_front") * 10};
                                   },
                                   o);
  EXPECT_EQ(calls, 12);
  EXPECT_EQ(seeds.size(), 12u);
  EXPECT_EQ(summary.falls, 3);
  EXPECT_NEAR(summary.cost_mean, 5.0, 0.05);
  EXPECT_GT(summary.cost_sd, 0.0);
}

}  // namespace
}  // namespace cpgmatch::analysis
