#include "dashboard_snapshot.hpp"

#include <algorithm>
#include <limits>
#include <set>

namespace cpgmatch::cli::dashboard {

using nlohmann::json;

namespace {

// A field of a report, or null where an older or partial record lacks it.
json field(const json& object, const char* key) {
  return object.is_object() && object.contains(key) ? object.at(key) : json(nullptr);
}

// The study's legs by name: its state's (an optimizer that publishes them), else its trial records' (the
// same names), else none (an older optimizer's: the page then names none).
json legs_of(const json& state, const std::vector<json>& records) {
  const json legs = field(state, "legs");
  if (legs.is_array() && !legs.empty()) return legs;
  for (const json& record : records) {
    const json from_record = field(record, "legs");
    if (from_record.is_array() && !from_record.empty()) return from_record;
  }
  return json::array();
}

// The searched parameters in the search space's order (the robot's); from an optimizer that does not publish
// its space, every name the trials carry, sorted.
json parameters_of(const json& state, const std::set<std::string>& from_trials) {
  json names = json::array();
  const json space = field(state, "search_space");
  if (space.is_array()) {
    for (const json& axis : space) {
      if (field(axis, "name").is_string()) names.push_back(axis.at("name"));
    }
  }
  return names.empty() ? json(from_trials) : names;
}

// The answer's energy per leg (the recommended trial, else the best one), each leg under its name: only this
// one trial's, since every trial's would make each update several times larger.
json answer_leg_energy(const json& state, const std::vector<json>& records, const json& legs) {
  const json recommended = field(state, "recommended_trial");
  const json best = field(state, "best_trial");
  const json& trial = recommended.is_number() ? recommended : best;
  if (!trial.is_number()) return nullptr;
  for (const json& record : records) {
    if (field(record, "trial_id") != trial) continue;
    const json joints = field(field(field(record, "report"), "energy"), "joints");
    const json hips = field(joints, "hip"), knees = field(joints, "knee");
    if (!hips.is_array() || !knees.is_array() || hips.size() != knees.size() || hips.size() != legs.size()) {
      return nullptr;  // not measured, or not nameable: nothing rather than a value under the wrong leg
    }
    json out = json::array();
    for (std::size_t leg = 0; leg < legs.size(); ++leg) {
      out.push_back({{"leg", legs[leg]},
                     {"hip_positive_work_j", field(hips[leg], "positive_work_j")},
                     {"knee_positive_work_j", field(knees[leg], "positive_work_j")},
                     {"hip_electrical_j", field(hips[leg], "electrical_j")},
                     {"knee_electrical_j", field(knees[leg], "electrical_j")}});
    }
    return {{"trial_id", trial}, {"recommended", recommended.is_number()}, {"legs", out}};
  }
  return nullptr;
}

}  // namespace

json trial_summary(const json& record) {
  const json report = field(record, "report");
  return {{"trial_id", field(record, "trial_id")},
          {"initial", field(record, "initial")},
          {"outcome", field(report, "outcome")},
          {"ok", field(report, "ok")},
          {"fell", field(report, "fell")},
          {"cost", field(report, "cost")},
          {"terms", field(report, "terms")},
          {"params", field(record, "params")},
          {"worker_id", field(report, "worker_id")},
          {"speed_mps", field(report, "mean_speed_mps")},
          {"normalized_torque", field(report, "normalized_torque")}};
}

json current_minimum(const std::vector<json>& summaries) {
  json out = json::array();
  double best = std::numeric_limits<double>::infinity();
  for (const json& t : summaries) {
    const json& cost = t.at("cost");
    if (t.at("ok") == true && cost.is_number()) best = std::min(best, cost.get<double>());
    out.push_back(best < std::numeric_limits<double>::infinity() ? json(best) : json(nullptr));
  }
  return out;
}

json snapshot_json(const DomainView& view) {
  json studies = json::array();
  for (auto it = view.states.rbegin(); it != view.states.rend(); ++it) {
    const int study_id = it->first;
    std::vector<json> summaries;
    std::set<std::string> parameters;
    static const std::vector<json> kNoRecords;
    const auto found = view.trials.find(study_id);
    const std::vector<json>& records = found != view.trials.end() ? found->second : kNoRecords;
    for (const json& record : records) {
      summaries.push_back(trial_summary(record));
      for (const auto& [name, value] : summaries.back()["params"].items()) parameters.insert(name);
    }
    const json legs = legs_of(it->second, records);
    studies.push_back({{"state", it->second},
                       {"trials", summaries},
                       {"current_minimum", current_minimum(summaries)},
                       {"parameters", parameters_of(it->second, parameters)},
                       {"legs", legs},
                       {"leg_energy", answer_leg_energy(it->second, records, legs)}});
  }
  // What each worker last reported, from the trial records: a worker's announcement says how busy it is, not
  // with what, and the optimizer's candidates, which say it, are not for a viewer to read (make-study-pki.sh).
  // The newest study and the highest trial id in it win.
  std::map<std::string, json> last_trial;
  std::map<std::string, std::pair<int, int>> newest;
  for (const auto& [study_id, records] : view.trials) {
    for (const json& record : records) {
      const json worker = field(field(record, "report"), "worker_id");
      if (!worker.is_string()) continue;
      const std::pair<int, int> order{study_id, field(record, "trial_id").is_number() ? record.at("trial_id").get<int>() : 0};
      const std::string id = worker.get<std::string>();
      if (const auto seen = newest.find(id); seen != newest.end() && seen->second > order) continue;
      newest[id] = order;
      last_trial[id] = {{"study_id", study_id}, {"trial_id", order.second},
                        {"outcome", field(field(record, "report"), "outcome")}};
    }
  }
  json workers = json::array();
  for (const auto& [id, announcement] : view.workers) {
    json w = announcement;
    const auto found = last_trial.find(id);
    w["last_trial"] = found == last_trial.end() ? json(nullptr) : found->second;
    workers.push_back(std::move(w));
  }
  return {{"domain", view.domain}, {"optimizer_heard", view.optimizer_heard}, {"studies", studies}, {"workers", workers}};
}

}  // namespace cpgmatch::cli::dashboard
