#include "cpgmatch/domain/rollout_report.hpp"

#include <utility>

#include <fmt/format.h>

namespace cpgmatch::domain {

RolloutReport report_of(const RolloutResult& result) {
  RolloutReport r;
  r.outcome = outcome_of(result.outcome);
  if (!r.ok()) r.error = result.outcome_message;
  const CostBreakdown& b = result.breakdown;
  r.summary.cost = result.cost;
  r.summary.terms = b.terms;
  r.summary.feedback = b.feedback_fraction;
  r.summary.normalized_torque = b.normalized_torque;
  r.summary.summed_torque_nm = b.summed_torque_nm;
  r.summary.fall_time_s = r.fell() ? result.fall_time_s : -1.0;
  r.summary.distance_m = b.distance_m;
  r.summary.mean_speed_mps = b.mean_speed_mps;
  r.summary.energy = result.energy;
  r.wall_time_s = result.wall_time_s;
  return r;
}

std::optional<std::string> check_report(const RolloutReport& r) {
  if (r.worker_id.empty()) return std::string("empty worker_id");
  if (r.id.study_id < 0 || r.id.trial_id < 0 || r.id.attempt < 0) {
    return fmt::format("negative id (study {}, trial {}, attempt {})", r.id.study_id, r.id.trial_id, r.id.attempt);
  }
  if (!r.ok()) return std::nullopt;  // a report that did not measure carries only its reason
  const RolloutSummary& s = r.summary;
  const std::pair<const char*, double> finite[] = {
      {"cost", s.cost},           {"j_feedback", s.terms.feedback}, {"j_distance", s.terms.distance},
      {"j_pitch", s.terms.pitch}, {"j_contact", s.terms.contact},   {"j_periodicity", s.terms.periodicity},
      {"distance_m", s.distance_m}, {"wall_time_s", r.wall_time_s}};
  for (const auto& [name, value] : finite) {
    if (!std::isfinite(value)) return fmt::format("{} is not finite ({})", name, value);
  }
  if (r.wall_time_s < 0.0) return std::string("wall_time_s is negative");
  return std::nullopt;
}

}  // namespace cpgmatch::domain
