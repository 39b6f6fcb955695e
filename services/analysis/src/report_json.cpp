// to_json(ScienceReport): every statistic, NaN as null.
#include <cmath>

#include "cpgmatch/analysis/paper_values.hpp"
#include "cpgmatch/analysis/science_report.hpp"

namespace cpgmatch::analysis {
namespace {

nlohmann::json number(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }

nlohmann::json terms_json(const CostTerms& t) {
  return {{"feedback", number(t.feedback)},
          {"distance", number(t.distance)},
          {"pitch", number(t.pitch)},
          {"contact", number(t.contact)},
          {"periodicity", number(t.periodicity)}};
}

}  // namespace

nlohmann::json to_json(const ScienceReport& r) {
  nlohmann::json windows = nlohmann::json::array();
  for (const auto& w : r.windows) {
    windows.push_back({{"first", w.window.first},
                       {"last", w.window.last},
                       {"rollouts", w.rollouts},
                       {"falls", w.falls},
                       {"walked", w.walked},
                       {"feedback_mean", number(w.feedback_mean)},
                       {"feedback_median", number(w.feedback_median)},
                       {"normalized_torque_median", number(w.normalized_torque_median)},
                       {"summed_torque_median_nm", number(w.summed_torque_median_nm)},
                       {"speed_mean_mps", number(w.speed_mean_mps)}});
  }
  nlohmann::json params = nlohmann::json::object();
  for (const auto& [k, v] : r.best_params) params[k] = number(v);
  nlohmann::json measures = nlohmann::json::object();
  for (const MeasureStats& m : r.measures) {
    measures[m.key] = {{"initial_median", number(m.initial_median)},
                       {"late_median", number(m.late_median)},
                       {"ratio", number(m.ratio)},
                       {"samples", m.samples},
                       {"rho_feedback", number(m.rho_feedback)},
                       {"rho_feedback_residual", number(m.rho_feedback_residual)},
                       {"rho_feedback_partial", number(m.rho_feedback_partial)},
                       {"speed_exponent", number(m.speed_exponent)}};
  }
  nlohmann::json j{
      {"name", r.name},
      {"study_id", r.study_id},
      {"rollouts", r.rollouts},
      {"failed_evaluations", r.failed_evaluations},
      {"synthetic_left_out", r.synthetic_left_out},
      {"initial_points", r.initial_points},
      {"falls",
       {{"total", r.falls},
        {"initial", r.falls_initial},
        {"after", r.falls_after},
        {"after_locations",
         {{"falls", r.falls_after_locations.falls},  // falls.after less those before any rollout ran
          {"walked", r.falls_after_locations.walked},
          {"falls_params_at_bound_median", number(r.falls_after_locations.falls_params_at_bound_median)},
          {"walked_params_at_bound_median", number(r.falls_after_locations.walked_params_at_bound_median)},
          {"falls_distance_to_best_median", number(r.falls_after_locations.falls_distance_to_best_median)},
          {"walked_distance_to_best_median", number(r.falls_after_locations.walked_distance_to_best_median)},
          {"falls_near_best", r.falls_after_locations.falls_near_best}}}}},
      {"windows", windows},
      {"learning",
       {{"late_first_rollout", r.late_first_rollout},
        {"feedback_initial_mean", number(r.feedback_initial_mean)},
        {"feedback_late_mean", number(r.feedback_late_mean)},
        {"feedback_ratio", number(r.feedback_ratio)},
        {"torque_initial_median", number(r.torque_initial_median)},
        {"torque_late_median", number(r.torque_late_median)},
        {"torque_ratio", number(r.torque_ratio)}}},
      {"cost",
       {{"mean", number(r.cost_mean)},
        {"sd", number(r.cost_sd)},
        {"median", number(r.cost_median)},
        {"worst", number(r.worst_cost)},
        {"worst_rollout", r.worst_rollout}}},
      {"normalized_torque", {{"mean", number(r.torque_mean)}, {"sd", number(r.torque_sd)}, {"median", number(r.torque_median)}}},
      {"best",
       {{"rollout", r.best_rollout},
        {"cost", number(r.best_cost)},
        {"fell", r.best_fell},
        {"speed_mps", number(r.best_speed_mps)},
        {"normalized_torque", number(r.best_normalized_torque)},
        {"terms", terms_json(r.best_terms)},
        {"params", params}}},
      {"correlations",
       {{"samples", r.correlation_samples},
        {"feedback_vs_torque", number(r.rho_feedback_torque)},
        {"feedback_vs_torque_residual", number(r.rho_feedback_torque_residual)},
        {"torque_speed_exponent", number(r.torque_speed_exponent)},
        {"feedback_vs_summed_torque", number(r.rho_feedback_summed_torque)}}},
      {"small_terms",
       {{"contact", number(r.fraction_contact_small)},
        {"periodicity", number(r.fraction_periodicity_small)},
        {"both", number(r.fraction_both_small)},
        {"best_quartile",
         {{"rollouts", r.small_terms_best_quartile.rollouts},
          {"contact", number(r.small_terms_best_quartile.contact)},
          {"periodicity", number(r.small_terms_best_quartile.periodicity)},
          {"both", number(r.small_terms_best_quartile.both)}}}}},
      {"measures", measures},
      {"eq1", {{"knee_steady_share_median", number(r.knee_steady_share_median)}}},
      {"recommended", nullptr},
      {"jitter", nullptr},
      {"paper", paper_values()},
  };
  if (r.recommendation) {
    const Recommendation& rec = *r.recommendation;
    nlohmann::json rec_params = nlohmann::json::object();
    for (const auto& [name, value] : rec.params) rec_params[name] = value;
    j["recommended"] = {{"rollout", rec.rollout},
                        {"predicted_cost", number(rec.predicted_cost)},
                        {"predicted_sd", number(rec.predicted_sd)},
                        {"observed_cost", number(rec.observed_cost)},
                        {"fell", rec.fell},
                        {"params", rec_params}};
  }
  if (r.jitter) {
    j["jitter"] = {{"draws", r.jitter->draws},         {"relative", r.jitter->relative}, {"failed", r.jitter->failed},
                   {"falls", r.jitter->falls},         {"cost_mean", number(r.jitter->cost_mean)},
                   {"cost_sd", number(r.jitter->cost_sd)}, {"costs", r.jitter->costs}};
  }
  return j;
}

}  // namespace cpgmatch::analysis
