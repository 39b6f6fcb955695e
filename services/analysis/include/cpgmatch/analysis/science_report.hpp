// The science of one finished study, statistic by statistic, for comparison with the paper.
//
// Design choices (docs/analysis.md has the reasons):
//  - Physical quantities (J_feedback, torques, speed) come from rollouts that did not fall only; a fall
//    ends the rollout early and its numbers describe a tumble, not a gait.
//  - Learning is measured by fixed windows of rollouts (1-15, 16-50, 51-100, 101-150), never by the best
//    rollout against the initial ones: the best rollout is selected for low cost, so comparing it with an
//    unselected median shows an "improvement" even for a search that learns nothing.
//  - Torque is confounded with speed: eq. 1 divides by the mean speed. The speed-corrected residual
//    (log normalised torque minus its least-squares fit on log speed) is what is left to correlate with
//    J_feedback once that dependence is removed.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "cpgmatch/analysis/energy_claim.hpp"
#include "cpgmatch/analysis/fall_locations.hpp"
#include "cpgmatch/analysis/recommendation.hpp"
#include "cpgmatch/analysis/jitter.hpp"
#include "cpgmatch/analysis/trial.hpp"

namespace cpgmatch::analysis {

struct Window {  // rollouts first..last, 1-based and inclusive
  int first = 1;
  int last = 1;
};

struct ReportOptions {
  std::vector<Window> windows = {{1, 15}, {16, 50}, {51, 100}, {101, 150}};
  int last_rollouts = 50;  // the "late" sample of the learning ratios
  // A good gait's J_contact and J_periodicity are each below this fraction of J_feedback + J_distance
  // ("an order of magnitude lower than the remaining cost terms").
  double small_term_fraction = 0.1;
};

struct WindowStats {
  Window window;            // clipped to the study's length
  int rollouts = 0;
  int falls = 0;
  int walked = 0;           // non-fallen rollouts: the sample of every quantity below
  double feedback_mean = 0.0;
  double feedback_median = 0.0;
  double normalized_torque_median = 0.0;  // N m / (m/s)
  double summed_torque_median_nm = 0.0;
  double speed_mean_mps = 0.0;
};

// The fractions of a set of rollouts whose J_contact, J_periodicity (and both) are below
// small_term_fraction x (J_feedback + J_distance).
struct SmallTerms {
  int rollouts = 0;
  double contact = 0.0;
  double periodicity = 0.0;
  double both = 0.0;
};
SmallTerms small_terms(const std::vector<const Trial*>& rollouts, double small_term_fraction);

struct ScienceReport {
  std::string name;
  int study_id = 0;
  int rollouts = 0;
  int failed_evaluations = 0;  // the rollout could not run at all (not a fall)
  int synthetic_left_out = 0;  // synthetic rollouts (--fake-rollout-ms) not counted anywhere in this report
  int initial_points = 0;
  int falls = 0, falls_initial = 0, falls_after = 0;
  FallLocations falls_after_locations;  // at the space's corners or next to the best (fall_locations.hpp)
  std::vector<WindowStats> windows;

  // Learning: the last `last_rollouts` rollouts against the initial design, non-fallen only.
  int late_first_rollout = 0;  // 1-based start of the late sample
  double feedback_initial_mean = 0.0, feedback_late_mean = 0.0, feedback_ratio = 0.0;
  double torque_initial_median = 0.0, torque_late_median = 0.0, torque_ratio = 0.0;

  // Costs over rollouts that ran (falls included: their cost is what the optimizer saw).
  double cost_mean = 0.0, cost_sd = 0.0, cost_median = 0.0, worst_cost = 0.0;
  int worst_rollout = 0;
  double torque_mean = 0.0, torque_sd = 0.0, torque_median = 0.0;  // non-fallen

  int best_rollout = 0;  // 1-based; 0 when no rollout ran
  double best_cost = 0.0;
  CostTerms best_terms;
  double best_speed_mps = 0.0;
  double best_normalized_torque = 0.0;
  bool best_fell = false;
  std::map<std::string, double> best_params;

  // Spearman's rho over non-fallen rollouts.
  int correlation_samples = 0;
  double rho_feedback_torque = 0.0;
  double rho_feedback_torque_residual = 0.0;  // residual of log(torque) ~ log(speed)
  double torque_speed_exponent = 0.0;         // slope of that fit; -1 would be a pure 1/speed dependence
  double rho_feedback_summed_torque = 0.0;

  // "J_contact and J_periodicity an order of magnitude lower than the other terms": over all non-fallen
  // rollouts (bad gaits pooled in), and over the good gaits the paper's sentence is about: the best
  // quartile by cost of the non-fallen rollouts.
  double fraction_contact_small = 0.0;      // of all non-fallen rollouts
  double fraction_periodicity_small = 0.0;
  double fraction_both_small = 0.0;
  SmallTerms small_terms_best_quartile;

  // The energy claim for every measure (energy_claim.hpp), and what dominates eq. 1.
  std::vector<MeasureStats> measures;
  double knee_steady_share_median = 0.0;

  // The study's answer: the rollout with the lowest GP posterior mean (recommendation.hpp). The jitter
  // test runs on these parameters.
  std::optional<Recommendation> recommendation;
  std::optional<JitterSummary> jitter;      // set by the caller when it ran the jitter test
};

ScienceReport science_report(const StudyTrials& study, const ReportOptions& options = {});

// The parameters a study answers with: the recommendation when there is one, else the best rollout's.
const std::map<std::string, double>& answer_params(const ScienceReport& r);

// Every statistic, each beside the paper's value where the paper gives one (key "paper").
nlohmann::json to_json(const ScienceReport& r);
// A human table: statistic, this study, the paper.
std::string format_table(const ScienceReport& r);

}  // namespace cpgmatch::analysis
