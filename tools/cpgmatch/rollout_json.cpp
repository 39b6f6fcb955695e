#include "rollout_json.hpp"

#include "cpgmatch/domain/report_json.hpp"

namespace cpgmatch::cli {

nlohmann::json params_to_json(const CpgParameters& p) {
  nlohmann::json j = nlohmann::json::object();
  for (const auto& [name, value] : to_map(p)) j[name] = value;
  return j;
}

nlohmann::json to_json(const RolloutResult& r) {
  const auto& b = r.breakdown;
  return {
      {"cost", r.cost},
      {"terms",
       {{"feedback", b.terms.feedback},
        {"distance", b.terms.distance},
        {"pitch", b.terms.pitch},
        {"contact", b.terms.contact},
        {"periodicity", b.terms.periodicity}}},
      {"normalized_torque", b.normalized_torque},
      {"summed_torque_nm", b.summed_torque_nm},
      {"outcome", to_string(r.outcome)},
      {"outcome_message", r.outcome_message},
      {"fell", r.fell},
      {"fall_time_s", r.fell ? nlohmann::json(r.fall_time_s) : nlohmann::json(nullptr)},
      {"distance_m", b.distance_m},
      {"mean_speed_mps", b.mean_speed_mps},
      {"feedback_fraction",
       {{"late_touchdown", b.feedback_fraction.late_touchdown},
        {"early_touchdown", b.feedback_fraction.early_touchdown},
        {"early_toeoff", b.feedback_fraction.early_toeoff},
        {"late_toeoff", b.feedback_fraction.late_toeoff}}},
      {"hip_tracking_rms_rad",
       r.hip_tracking_rms_rad >= 0.0 ? nlohmann::json(r.hip_tracking_rms_rad) : nlohmann::json(nullptr)},
      {"sim_time_s", r.sim_time_s},
      {"wall_time_s", r.wall_time_s},
      {"params", params_to_json(r.params)},
      {"energy", domain::to_json(r.energy)},
  };
}

}  // namespace cpgmatch::cli
