#include <fmt/format.h>

#include "cpgmatch/analysis/json_path.hpp"
#include "cpgmatch/analysis/paper_values.hpp"
#include "cpgmatch/analysis/report_rows.hpp"
#include "cpgmatch/analysis/science_report.hpp"

namespace cpgmatch::analysis {

namespace {

// Rows whose paths all lie under one prefix (a window, a measure).
void append_under(std::vector<TableRow>& rows, const std::string& prefix, const std::vector<TableRow>& relative) {
  for (const TableRow& row : relative) rows.push_back({row.label, prefix + row.path, row.decimals});
}

}  // namespace

std::vector<TableRow> report_rows(const nlohmann::json& report) {
  std::vector<TableRow> rows = {
      {"falls", "", 0},
      {"falls, all rollouts", "falls.total", 0},
      {"falls in the initial design", "falls.initial", 0},
      {"falls after it", "falls.after", 0},
      {"  where, after it (median; distance in the unit cube)", "", 0},
      {"    parameters at a bound: falls", "falls.after_locations.falls_params_at_bound_median", 1},
      {"    parameters at a bound: rollouts that walked", "falls.after_locations.walked_params_at_bound_median", 1},
      {"    distance to the best so far: falls", "falls.after_locations.falls_distance_to_best_median", 2},
      {"    distance to the best so far: walked", "falls.after_locations.walked_distance_to_best_median", 2},
      {"    falls within 0.15 of the best so far", "falls.after_locations.falls_near_best", 0},
      {"failed evaluations (did not run)", "failed_evaluations", 0},
      {"synthetic rollouts left out (--fake-rollout-ms, no gait)", "synthetic_left_out", 0},
  };
  const auto& windows = report.value("windows", nlohmann::json::array());
  for (std::size_t i = 0; i < windows.size(); ++i) {
    const std::string w = fmt::format("windows.{}.", i);
    rows.push_back({fmt::format("rollouts {}-{} (non-fallen for all but falls)", windows[i]["first"].get<int>(),
                                windows[i]["last"].get<int>()),
                    "", 0});
    append_under(rows, w,
                 {{"  rollouts", "rollouts", 0},
                  {"  falls", "falls", 0},
                  {"  J_feedback mean", "feedback_mean", 3},
                  {"  J_feedback median", "feedback_median", 3},
                  {"  normalised torque median, N m/(m/s)", "normalized_torque_median", 2},
                  {"  summed torque median, N m", "summed_torque_median_nm", 3},
                  {"  mean speed, m/s", "speed_mean_mps", 3}});
  }
  const std::vector<TableRow> rest = {
      {"learning: last rollouts vs initial design (non-fallen)", "", 0},
      {"  J_feedback mean, initial", "learning.feedback_initial_mean", 3},
      {"  J_feedback mean, last", "learning.feedback_late_mean", 3},
      {"  J_feedback ratio last / initial", "learning.feedback_ratio", 3},
      {"  normalised torque median, initial", "learning.torque_initial_median", 2},
      {"  normalised torque median, last", "learning.torque_late_median", 2},
      {"  normalised torque ratio last / initial", "learning.torque_ratio", 3},
      {"costs (rollouts that ran)", "", 0},
      {"  mean", "cost.mean", 3},
      {"  sd", "cost.sd", 3},
      {"  median", "cost.median", 3},
      {"  worst", "cost.worst", 3},
      {"  worst rollout", "cost.worst_rollout", 0},
      {"normalised torque (non-fallen), N m/(m/s)", "", 0},
      {"  mean", "normalized_torque.mean", 2},
      {"  sd", "normalized_torque.sd", 2},
      {"  median", "normalized_torque.median", 2},
      {"best rollout", "", 0},
      {"  rollout", "best.rollout", 0},
      {"  cost", "best.cost", 3},
      {"  J_feedback", "best.terms.feedback", 3},
      {"  J_distance", "best.terms.distance", 3},
      {"  J_pitch", "best.terms.pitch", 3},
      {"  J_contact", "best.terms.contact", 3},
      {"  J_periodicity", "best.terms.periodicity", 3},
      {"  speed, m/s", "best.speed_mps", 3},
      {"  normalised torque", "best.normalized_torque", 2},
      {"Spearman rho over non-fallen rollouts", "", 0},
      {"  J_feedback vs normalised torque", "correlations.feedback_vs_torque", 3},
      {"  J_feedback vs speed-corrected torque residual", "correlations.feedback_vs_torque_residual", 3},
      {"  J_feedback vs summed torque", "correlations.feedback_vs_summed_torque", 3},
      {"  fitted exponent of torque ~ speed^b", "correlations.torque_speed_exponent", 3},
      {"J_contact, J_periodicity < 0.1 (J_feedback + J_distance)", "", 0},
      {"  all non-fallen (bad gaits pooled in): J_contact", "small_terms.contact", 3},
      {"  all non-fallen: J_periodicity", "small_terms.periodicity", 3},
      {"  all non-fallen: both", "small_terms.both", 3},
      {"  good gaits (best quartile by cost): rollouts", "small_terms.best_quartile.rollouts", 0},
      {"  good gaits: J_contact", "small_terms.best_quartile.contact", 3},
      {"  good gaits: J_periodicity", "small_terms.best_quartile.periodicity", 3},
      {"  good gaits: both", "small_terms.best_quartile.both", 3},
      {"what the motors spend (non-fallen; rho: Spearman with J_feedback)", "", 0},
      {"  eq. 1: knees' steady torque, share of its numerator", "eq1.knee_steady_share_median", 3},
  };
  rows.insert(rows.end(), rest.begin(), rest.end());
  for (const auto& m : energy_measures()) {
    rows.push_back({fmt::format("  {}", m.label), "", 0});
    append_under(rows, fmt::format("measures.{}.", m.key),
                 {{"    median, initial design", "initial_median", 3},
                  {"    median, last rollouts", "late_median", 3},
                  {"    ratio last / initial", "ratio", 3},
                  {"    rho", "rho_feedback", 3},
                  {"    rho at equal speed (log residual)", "rho_feedback_residual", 3},
                  {"    rho at equal speed (partial)", "rho_feedback_partial", 3},
                  {"    exponent b of measure ~ speed^b", "speed_exponent", 3}});
  }
  if (report.contains("recommended") && report["recommended"].is_object()) {
    rows.push_back({"recommended: the rollout with the lowest GP posterior mean", "", 0});
    rows.push_back({"  rollout", "recommended.rollout", 0});
    rows.push_back({"  predicted cost", "recommended.predicted_cost", 3});
    rows.push_back({"  its own rollout's cost", "recommended.observed_cost", 3});
  }
  if (report.contains("jitter") && report["jitter"].is_object()) {
    rows.push_back({fmt::format("recommended parameters under +-{:.0f}% jitter", 100 * report["jitter"]["relative"].get<double>()),
                    "", 0});
    rows.push_back({"  draws", "jitter.draws", 0});
    rows.push_back({"  falls", "jitter.falls", 0});
    rows.push_back({"  cost mean", "jitter.cost_mean", 3});
    rows.push_back({"  cost sd", "jitter.cost_sd", 3});
  }
  return rows;
}

std::string format_value(const nlohmann::json& v, int decimals) {
  if (v.is_null()) return "-";
  if (v.is_string()) return v.get<std::string>();
  if (v.is_boolean()) return v.get<bool>() ? "yes" : "no";
  if (v.is_number_integer()) return std::to_string(v.get<long long>());
  return fmt::format("{:.{}f}", v.get<double>(), decimals);
}

std::string format_table(const ScienceReport& r) {
  const nlohmann::json j = to_json(r);
  std::string out = fmt::format("study '{}' (id {}): {} rollouts, {} in the random initial design\n", r.name,
                                r.study_id, r.rollouts, r.initial_points);
  out += fmt::format("{:<56} {:>12}  {}\n", "statistic", "this study", "paper (Ruppert & Badri-Sproewitz 2022)");
  for (const auto& row : report_rows(j)) {
    if (row.path.empty()) {
      out += row.label + "\n";
      continue;
    }
    // Window rows have no paper counterpart of their own; the paper's falls split is printed with falls.
    const nlohmann::json paper = paper_value(row.path);
    out += fmt::format("{:<56} {:>12}  {}\n", row.label, format_value(json_at(j, row.path), row.decimals),
                       paper.is_null() ? "" : format_value(paper, row.decimals));
  }
  out += eq1_sentence(r.knee_steady_share_median) + "\n";
  if (!r.best_params.empty()) {
    // The study's answer (best_params.yaml): the recommendation when there is one.
    out += r.recommendation ? "recommended parameters:" : "best parameters:";
    for (const auto& [k, v] : answer_params(r)) out += fmt::format(" {}={:.4f}", k, v);
    out += "\n";
  }
  return out;
}

}  // namespace cpgmatch::analysis
