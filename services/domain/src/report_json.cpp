#include "cpgmatch/domain/report_json.hpp"

#include <cmath>
#include <stdexcept>

namespace cpgmatch::domain {

namespace {

// JSON has no NaN: a missing value (no best cost yet, a report that did not measure) is null.
nlohmann::json number(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }
double number_of(const nlohmann::json& v) { return v.is_null() ? std::nan("") : v.get<double>(); }

nlohmann::json params_json(const std::map<std::string, double>& named) {
  nlohmann::json j = nlohmann::json::object();
  for (const auto& [name, value] : named) j[name] = value;
  return j;
}

nlohmann::json search_space_json(const std::vector<SearchAxis>& space) {
  nlohmann::json out = nlohmann::json::array();
  for (const SearchAxis& a : space) {
    out.push_back({{"name", a.name}, {"low", a.low}, {"high", a.high}, {"log", a.log_scale}, {"unit", a.unit}});
  }
  return out;
}

double number_or_nan(const nlohmann::json& j, const char* key) {
  return j.is_object() && j.contains(key) && j.at(key).is_number() ? j.at(key).get<double>() : std::nan("");
}

// The energy object's scalar fields, one list for writing and reading.
template <typename Energy, typename F>
void for_each_energy_total(Energy& e, F f) {
  f("positive_work_j", e.positive_work_j);
  f("joule_loss_j", e.joule_loss_j);
  f("electrical_j", e.electrical_j);
  f("hip_positive_work_j_per_m", e.hip_positive_work_j_per_m);
  f("knee_positive_work_j_per_m", e.knee_positive_work_j_per_m);
  f("positive_work_j_per_m", e.positive_work_j_per_m);
  f("mechanical_cost_of_transport", e.mechanical_cost_of_transport);
  f("electrical_cost_of_transport", e.electrical_cost_of_transport);
  f("signed_torque_per_speed", e.signed_torque_per_speed);
}

template <typename Joint, typename F>
void for_each_joint_field(Joint& j, F f) {
  f("positive_work_j", j.positive_work_j);
  f("joule_loss_j", j.joule_loss_j);
  f("electrical_j", j.electrical_j);
  f("signed_mean_torque_nm", j.signed_mean_torque_nm);
}

nlohmann::json joints_json(const PerLeg<JointEnergy>& joints) {
  nlohmann::json out = nlohmann::json::array();
  for (const JointEnergy& joint : joints) {
    nlohmann::json j = nlohmann::json::object();
    for_each_joint_field(joint, [&](const char* key, double v) { j[key] = number(v); });
    out.push_back(j);
  }
  return out;
}

void joints_from_json(const nlohmann::json& j, PerLeg<JointEnergy>& joints) {
  if (!j.is_array()) return;
  joints = PerLeg<JointEnergy>(std::min<std::size_t>(j.size(), kMaxLegs));  // one per leg the report had
  for (std::size_t leg = 0; leg < joints.size(); ++leg) {
    for_each_joint_field(joints[leg], [&](const char* key, double& v) { v = number_or_nan(j[leg], key); });
  }
}

}  // namespace

nlohmann::json to_json(const EnergyMeasures& e) {
  nlohmann::json j = nlohmann::json::object();
  for_each_energy_total(e, [&](const char* key, double v) { j[key] = number(v); });
  j["joints"] = {{"hip", joints_json(e.hip)}, {"knee", joints_json(e.knee)}};
  return j;
}

EnergyMeasures energy_from_json(const nlohmann::json& j) {
  EnergyMeasures e;
  if (!j.is_object()) return e;
  for_each_energy_total(e, [&](const char* key, double& v) { v = number_or_nan(j, key); });
  if (j.contains("joints") && j.at("joints").is_object()) {
    const auto& joints = j.at("joints");
    if (joints.contains("hip")) joints_from_json(joints.at("hip"), e.hip);
    if (joints.contains("knee")) joints_from_json(joints.at("knee"), e.knee);
  }
  return e;
}

nlohmann::json to_json(const RolloutReport& r) {
  const RolloutSummary& s = r.summary;
  nlohmann::json j = {{"study_id", r.id.study_id},
                      {"trial_id", r.id.trial_id},
                      {"attempt", r.id.attempt},
                      {"worker_id", r.worker_id},
                      {"worker_kind", to_string(r.worker_kind)},
                      {"ok", r.ok()},
                      {"outcome", to_string(r.outcome)},
                      {"error", r.error},
                      {"cost", number(s.cost)},
                      {"terms",
                       {{"feedback", number(s.terms.feedback)},
                        {"distance", number(s.terms.distance)},
                        {"pitch", number(s.terms.pitch)},
                        {"contact", number(s.terms.contact)},
                        {"periodicity", number(s.terms.periodicity)}}},
                      {"normalized_torque", number(s.normalized_torque)},
                      {"summed_torque_nm", number(s.summed_torque_nm)},
                      {"feedback_fraction",
                       {{"late_touchdown", number(s.feedback.late_touchdown)},
                        {"early_touchdown", number(s.feedback.early_touchdown)},
                        {"early_toeoff", number(s.feedback.early_toeoff)},
                        {"late_toeoff", number(s.feedback.late_toeoff)}}},
                      {"fell", r.fell()},
                      {"fall_time_s", number(s.fall_time_s)},
                      {"distance_m", number(s.distance_m)},
                      {"mean_speed_mps", number(s.mean_speed_mps)},
                      {"wall_time_s", number(r.wall_time_s)},
                      {"energy", to_json(s.energy)}};
  // Only hardware reports time a control loop; simulation reports keep their shape.
  if (r.worker_kind == WorkerKind::kHardware) {
    j["loop"] = {{"jitter_p50_us", number(r.loop.jitter_p50_us)},
                 {"jitter_p99_us", number(r.loop.jitter_p99_us)},
                 {"jitter_max_us", number(r.loop.jitter_max_us)},
                 {"overruns", r.loop.overruns}};
  }
  // Written only when set: a real rollout's report keeps its shape (and a study its bytes).
  if (r.synthetic) j["synthetic"] = true;
  return j;
}

RolloutReport report_from_json(const nlohmann::json& j) {
  RolloutReport r;
  r.id.study_id = j.at("study_id").get<int>();
  r.id.trial_id = j.at("trial_id").get<int>();
  r.id.attempt = j.at("attempt").get<int>();
  r.worker_id = j.at("worker_id").get<std::string>();
  r.worker_kind = j.at("worker_kind").get<std::string>() == "hardware" ? WorkerKind::kHardware : WorkerKind::kSimulation;
  r.error = j.at("error").get<std::string>();
  r.synthetic = j.value("synthetic", false);
  const bool ok = j.at("ok").get<bool>();
  if (j.contains("outcome")) {
    const auto outcome = outcome_from_string(j.at("outcome").get<std::string>());
    if (!outcome) throw std::runtime_error("unknown outcome " + j.at("outcome").dump());
    r.outcome = *outcome;
  } else {
    // Stores from before outcomes: a report that ran completed or fell, one that did not was an error.
    r.outcome = !ok ? Outcome::kError : j.at("fell").get<bool>() ? Outcome::kFell : Outcome::kCompleted;
  }
  RolloutSummary& s = r.summary;
  s.cost = number_of(j.at("cost"));
  const auto& t = j.at("terms");
  s.terms.feedback = number_of(t.at("feedback"));
  s.terms.distance = number_of(t.at("distance"));
  s.terms.pitch = number_of(t.at("pitch"));
  s.terms.contact = number_of(t.at("contact"));
  s.terms.periodicity = number_of(t.at("periodicity"));
  s.normalized_torque = number_of(j.at("normalized_torque"));
  s.summed_torque_nm = j.contains("summed_torque_nm") ? number_of(j.at("summed_torque_nm")) : std::nan("");
  const auto& f = j.at("feedback_fraction");
  s.feedback.late_touchdown = number_of(f.at("late_touchdown"));
  s.feedback.early_touchdown = number_of(f.at("early_touchdown"));
  s.feedback.early_toeoff = number_of(f.at("early_toeoff"));
  s.feedback.late_toeoff = number_of(f.at("late_toeoff"));
  s.fall_time_s = number_of(j.at("fall_time_s"));
  s.distance_m = number_of(j.at("distance_m"));
  s.mean_speed_mps = number_of(j.at("mean_speed_mps"));
  r.wall_time_s = number_of(j.at("wall_time_s"));
  // Stores from before energy have none: every energy field stays NaN.
  if (j.contains("energy")) s.energy = energy_from_json(j.at("energy"));
  if (j.contains("loop")) {
    const auto& l = j.at("loop");
    r.loop.jitter_p50_us = number_of(l.at("jitter_p50_us"));
    r.loop.jitter_p99_us = number_of(l.at("jitter_p99_us"));
    r.loop.jitter_max_us = number_of(l.at("jitter_max_us"));
    r.loop.overruns = l.at("overruns").get<int>();
  }
  return r;
}

nlohmann::json to_json(const StudyState& s) {
  const bool has_best = std::isfinite(s.best_cost);
  const nlohmann::json none(nullptr);
  return {{"study_id", s.study_id},
          {"name", s.name},
          {"state", to_string(s.status)},
          {"budget", s.budget},
          {"completed", s.completed},
          {"in_flight", s.in_flight},
          {"failed", s.failed},
          {"falls", s.falls},
          {"reissued", s.reissued},
          {"workers", s.workers},
          {"best_cost", number(s.best_cost)},
          {"best_trial", has_best ? nlohmann::json(s.best_trial) : none},
          {"best_params", has_best ? params_json(s.best_params) : none},
          {"recommended_trial", s.has_recommendation ? nlohmann::json(s.recommendation.trial) : none},
          {"recommended_predicted_cost", s.has_recommendation ? number(s.recommendation.predicted_cost) : none},
          {"recommended_params", s.has_recommendation ? params_json(s.recommendation.params) : none},
          {"best_normalized_torque", number(s.best_normalized_torque)},
          {"best_speed_mps", number(s.best_speed_mps)},
          {"elapsed_s", number(s.elapsed_s)},
          {"rollouts_per_s", number(s.rollouts_per_s)},
          {"message", s.message},
          {"legs", s.leg_names},
          {"search_space", search_space_json(s.search_space)}};
}

nlohmann::json to_json(const WorkerAnnouncement& w) {
  return {{"worker_id", w.worker_id},     {"kind", to_string(w.kind)},   {"host", w.host},
          {"pid", w.pid},                 {"slots", w.slots},            {"busy", w.busy},
          {"completed", w.completed},     {"accepting", w.accepting},    {"status", w.status},
          {"objective_version", w.objective_version}};
}

nlohmann::json to_json(const TrialRecord& t) {
  return {{"study_id", t.study_id},
          {"trial_id", t.trial_id},
          {"initial", t.initial},
          {"enqueued", t.enqueued},
          {"params", params_json(t.parameters)},
          {"report", to_json(t.report)},
          {"legs", t.leg_names}};
}

}  // namespace cpgmatch::domain
