#include "cpgmatch/dds/json.hpp"

#include <cmath>

#include "cpgmatch/dds/convert.hpp"

namespace cpgmatch::dds {

namespace {

// JSON has no NaN: a missing value (no best cost yet) becomes null.
nlohmann::json number(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }

nlohmann::json params_json(const std::vector<msg::ParameterValue>& values) {
  nlohmann::json j = nlohmann::json::object();
  for (const auto& [name, value] : from_wire(values)) j[name] = value;
  return j;
}

}  // namespace

nlohmann::json to_json(const msg::RolloutReport& r) {
  nlohmann::json j = {{"study_id", r.study_id()},
          {"trial_id", r.trial_id()},
          {"attempt", r.attempt()},
          {"worker_id", r.worker_id().to_string()},
          {"worker_kind", to_string(r.worker_kind())},
          {"ok", r.ok()},
          {"outcome", to_string(r.outcome())},
          {"error", r.error().to_string()},
          {"cost", number(r.cost())},
          {"terms",
           {{"feedback", number(r.j_feedback())},
            {"distance", number(r.j_distance())},
            {"pitch", number(r.j_pitch())},
            {"contact", number(r.j_contact())},
            {"periodicity", number(r.j_periodicity())}}},
          {"normalized_torque", number(r.normalized_torque())},
          {"summed_torque_nm", number(r.summed_torque_nm())},
          {"feedback_fraction",
           {{"late_touchdown", number(r.late_touchdown_fraction())},
            {"early_touchdown", number(r.early_touchdown_fraction())},
            {"early_toeoff", number(r.early_toeoff_fraction())},
            {"late_toeoff", number(r.late_toeoff_fraction())}}},
          {"fell", r.fell()},
          {"fall_time_s", number(r.fall_time_s())},
          {"distance_m", number(r.distance_m())},
          {"mean_speed_mps", number(r.mean_speed_mps())},
          {"wall_time_s", number(r.wall_time_s())}};
  // Only hardware reports time a control loop; simulation reports keep their shape.
  if (r.worker_kind() == msg::WORKER_HARDWARE) {
    j["loop"] = {{"jitter_p50_us", number(r.loop_jitter_p50_us())},
                 {"jitter_p99_us", number(r.loop_jitter_p99_us())},
                 {"jitter_max_us", number(r.loop_jitter_max_us())},
                 {"overruns", r.loop_overruns()}};
  }
  return j;
}

msg::RolloutReport report_from_json(const nlohmann::json& j) {
  auto num = [](const nlohmann::json& v) { return v.is_null() ? std::nan("") : v.get<double>(); };
  msg::RolloutReport r;
  r.study_id(j.at("study_id").get<std::uint32_t>());
  r.trial_id(j.at("trial_id").get<std::uint32_t>());
  r.attempt(j.at("attempt").get<std::uint32_t>());
  r.worker_id(j.at("worker_id").get<std::string>());
  r.worker_kind(j.at("worker_kind").get<std::string>() == "hardware" ? msg::WORKER_HARDWARE : msg::WORKER_SIM);
  r.ok(j.at("ok").get<bool>());
  r.error(j.at("error").get<std::string>());
  // Stores from before outcomes: a report that ran completed or fell, one that did not was an error.
  const std::optional<msg::RolloutOutcome> outcome =
      j.contains("outcome") ? outcome_from_string(j.at("outcome").get<std::string>()) : std::nullopt;
  if (j.contains("outcome") && !outcome) throw std::runtime_error("unknown outcome " + j.at("outcome").dump());
  r.outcome(outcome ? *outcome
                    : !r.ok()                     ? msg::OUTCOME_ERROR
                    : j.at("fell").get<bool>()    ? msg::OUTCOME_FELL
                                                  : msg::OUTCOME_COMPLETED);
  r.cost(num(j.at("cost")));
  const auto& t = j.at("terms");
  r.j_feedback(num(t.at("feedback")));
  r.j_distance(num(t.at("distance")));
  r.j_pitch(num(t.at("pitch")));
  r.j_contact(num(t.at("contact")));
  r.j_periodicity(num(t.at("periodicity")));
  r.normalized_torque(num(j.at("normalized_torque")));
  r.summed_torque_nm(j.contains("summed_torque_nm") ? num(j.at("summed_torque_nm")) : std::nan(""));
  const auto& f = j.at("feedback_fraction");
  r.late_touchdown_fraction(num(f.at("late_touchdown")));
  r.early_touchdown_fraction(num(f.at("early_touchdown")));
  r.early_toeoff_fraction(num(f.at("early_toeoff")));
  r.late_toeoff_fraction(num(f.at("late_toeoff")));
  r.fell(j.at("fell").get<bool>());
  r.fall_time_s(num(j.at("fall_time_s")));
  r.distance_m(num(j.at("distance_m")));
  r.mean_speed_mps(num(j.at("mean_speed_mps")));
  r.wall_time_s(num(j.at("wall_time_s")));
  if (j.contains("loop")) {
    const auto& l = j.at("loop");
    r.loop_jitter_p50_us(num(l.at("jitter_p50_us")));
    r.loop_jitter_p99_us(num(l.at("jitter_p99_us")));
    r.loop_jitter_max_us(num(l.at("jitter_max_us")));
    r.loop_overruns(l.at("overruns").get<std::uint32_t>());
  }
  return r;
}

nlohmann::json to_json(const msg::StudyState& s) {
  return {{"study_id", s.study_id()},
          {"name", s.name().to_string()},
          {"state", to_string(s.state())},
          {"budget", s.budget()},
          {"completed", s.completed()},
          {"in_flight", s.in_flight()},
          {"failed", s.failed()},
          {"falls", s.falls()},
          {"reissued", s.reissued()},
          {"workers", s.workers()},
          {"best_cost", number(s.best_cost())},
          {"best_trial", std::isfinite(s.best_cost()) ? nlohmann::json(s.best_trial()) : nlohmann::json(nullptr)},
          {"best_params", std::isfinite(s.best_cost()) ? params_json(s.best_params()) : nlohmann::json(nullptr)},
          {"recommended_trial", s.has_recommendation() ? nlohmann::json(s.recommended_trial()) : nlohmann::json(nullptr)},
          {"recommended_predicted_cost",
           s.has_recommendation() ? number(s.recommended_predicted_cost()) : nlohmann::json(nullptr)},
          {"recommended_params", s.has_recommendation() ? params_json(s.recommended_params()) : nlohmann::json(nullptr)},
          {"best_normalized_torque", number(s.best_normalized_torque())},
          {"best_speed_mps", number(s.best_speed_mps())},
          {"elapsed_s", number(s.elapsed_s())},
          {"rollouts_per_s", number(s.rollouts_per_s())},
          {"message", s.message().to_string()}};
}

nlohmann::json to_json(const msg::WorkerAnnouncement& w) {
  return {{"worker_id", w.worker_id().to_string()},
          {"kind", to_string(w.kind())},
          {"host", w.host().to_string()},
          {"pid", w.pid()},
          {"slots", w.slots()},
          {"busy", w.busy()},
          {"completed", w.completed()},
          {"accepting", w.accepting()},
          {"status", w.status().to_string()},
          {"objective_version", w.objective_version()}};
}

nlohmann::json to_json(const msg::TrialRecord& t) {
  return {{"study_id", t.study_id()},
          {"trial_id", t.trial_id()},
          {"initial", t.initial()},
          {"params", params_json(t.parameters())},
          {"report", to_json(t.report())}};
}

}  // namespace cpgmatch::dds
