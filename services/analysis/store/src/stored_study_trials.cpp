#include "cpgmatch/analysis/stored_study_trials.hpp"

#include <algorithm>
#include <filesystem>

#include <fmt/format.h>

#include "cpgmatch/bo/model_state_json.hpp"
#include "cpgmatch/errors.hpp"
#include "cpgmatch/legs.hpp"
#include "cpgmatch/study/study_spec.hpp"

namespace cpgmatch::analysis {

study::StudyConfig stored_study_config(const study::StoredStudy& stored) {
  try {
    // The spec's own config when there is one: its space is the one the study searched (a robot's, when the
    // study names one), which the submitted text alone does not say. Older stores: the text.
    if (!stored.spec.json.empty()) {
      return study::StudySpec::from_json_text(stored.spec.json, fmt::format("study {} spec", stored.study_id)).config();
    }
    return study::load_study_config_text(stored.config_yaml, stored.source_name);
  } catch (const std::exception& e) {
    throw std::runtime_error(fmt::format("the store's copy of study {} (submitted from {}) is damaged: {}",
                                         stored.study_id, stored.source_name, e.what()));
  }
}

std::vector<std::string> stored_study_leg_names(const study::StoredStudy& stored) {
  if (stored.spec.json.empty()) return LegLayout::quadruped().names;  // before specs, every study was Morti's
  try {
    const auto spec = study::StudySpec::from_json_text(stored.spec.json, fmt::format("study {} spec", stored.study_id));
    return spec.rollout_settings().controller.legs.names;
  } catch (const std::exception& e) {
    throw std::runtime_error(fmt::format("the store's copy of study {} (submitted from {}) is damaged: {}",
                                         stored.study_id, stored.source_name, e.what()));
  }
}

void require_every_trial_readable(const std::vector<study::StoredStudy>& studies, const std::string& store_path) {
  std::vector<std::string> bad;
  for (const auto& s : studies) {
    for (const auto& why : s.unreadable_trials) bad.push_back(fmt::format("study {} {}", s.study_id, why));
  }
  if (bad.empty()) return;
  std::string list;
  for (const auto& b : bad) list += "\n  " + b;
  throw std::runtime_error(fmt::format("study store {}: {} trial row(s) cannot be read; nothing was exported or "
                                       "reported (`cpgmatch store check --store {}` checks the whole file):{}",
                                       store_path, bad.size(), store_path, list));
}

StudyTrials trials_from_stored_study(const study::StoredStudy& stored) {
  const study::StudyConfig cfg = stored_study_config(stored);
  StudyTrials s;
  s.name = stored.name;
  s.study_id = stored.study_id;
  s.initial_points = cfg.optimizer.initial_points;
  s.seed = cfg.optimizer.seed;
  for (const auto& d : cfg.space.dimensions()) {
    s.bounds[d.name] = {d.low, d.high};
    s.dimensions.push_back({d.name, d.low, d.high, d.log_scale, d.unit});
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
  if (!std::filesystem::exists(store_path)) {
    throw InputError(fmt::format("--store '{}': no such study store", store_path));
  }
  const study::StudyStore store(store_path, study::kReadOnly);
  auto all = store.load_all();
  if (all.empty()) throw InputError(fmt::format("--store '{}': the store holds no study", store_path));
  study::StoredStudy chosen = all.back();
  if (study_id > 0) {
    const auto it = std::find_if(all.begin(), all.end(), [&](const auto& s) { return s.study_id == study_id; });
    if (it == all.end()) throw InputError(fmt::format("--study {}: no such study in {}", study_id, store_path));
    chosen = *it;
  }
  require_every_trial_readable({chosen}, store_path);
  return chosen;
}

}  // namespace cpgmatch::analysis
