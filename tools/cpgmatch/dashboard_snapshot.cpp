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
    if (const auto found = view.trials.find(study_id); found != view.trials.end()) {
      for (const json& record : found->second) {
        summaries.push_back(trial_summary(record));
        for (const auto& [name, value] : summaries.back()["params"].items()) parameters.insert(name);
      }
    }
    studies.push_back({{"state", it->second},
                       {"trials", summaries},
                       {"current_minimum", current_minimum(summaries)},
                       {"parameters", parameters}});
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
