#include "cpgmatch/analysis/stored_study_trials.hpp"

#include <algorithm>
#include <filesystem>

#include <fmt/format.h>

#include "cpgmatch/bo/model_state_json.hpp"
#include "cpgmatch/errors.hpp"

namespace cpgmatch::analysis {

StudyTrials trials_from_stored_study(const study::StoredStudy& stored) {
  const study::StudyConfig cfg = study::load_study_config_text(stored.config_yaml, stored.source_name);
  StudyTrials s;
  s.name = stored.name;
  s.study_id = stored.study_id;
  s.initial_points = cfg.optimizer.initial_points;
  s.seed = cfg.optimizer.seed;
  for (const auto& d : cfg.space.dimensions()) {
    s.bounds[d.name] = {d.low, d.high};
    s.dimensions.push_back({d.name, d.low, d.high, d.log_scale});
  }
  s.log_cost = cfg.optimizer.cost_transform == bo::CostTransform::kLog;
  if (!stored.model_state.is_null()) {
    try {
      const bo::ModelState m = bo::model_state_from_json(stored.model_state);
      if (m.have_hyperparameters) {
        s.model_hyperparameters.assign(m.hyperparameters.data(), m.hyperparameters.data() + m.hyperparameters.size());
        s.model_observations = m.observations;
      }
    } catch (const std::exception&) {
      // An unreadable saved state: the figures of the model refit it from the rollouts instead.
    }
  }
  std::vector<study::StoredTrial> done;
  for (const auto& t : stored.trials) {
    if (t.status == study::TrialStatus::kDone) done.push_back(t);
  }
  std::sort(done.begin(), done.end(), [](const auto& a, const auto& b) { return a.trial_id < b.trial_id; });
  for (const auto& t : done) {
    // A failed evaluation's report may lack the numbers; trial_from_report keys off `ok` first.
    nlohmann::json report = t.report.is_object() ? t.report : nlohmann::json::object();
    report["ok"] = t.ok;
    s.trials.push_back(trial_from_report(t.trial_id, report, cfg.space.to_named(t.x)));
  }
  return s;
}

study::StoredStudy load_stored_study(const std::string& store_path, int study_id) {
  if (!std::filesystem::is_regular_file(store_path)) {
    throw InputError(fmt::format("--store '{}': no such study store", store_path));
  }
  const study::StudyStore store(store_path);
  if (study_id > 0) {
    auto s = store.load(study_id);
    if (!s) throw InputError(fmt::format("--study {}: no such study in {}", study_id, store_path));
    return *s;
  }
  auto all = store.load_all();
  if (all.empty()) throw InputError(fmt::format("--store '{}': the store holds no study", store_path));
  return all.back();
}

}  // namespace cpgmatch::analysis
