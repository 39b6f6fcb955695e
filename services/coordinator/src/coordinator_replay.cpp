// The Coordinator's restart half: reopening every study from the store (spec, observations, the saved model
// state, trials in flight) exactly as the uninterrupted service had it. Kept apart from the live event
// handling in coordinator.cpp; both are members of one class because a submitted study opens the same way.
#include <algorithm>

#include <fmt/format.h>

#include "cpgmatch/bo/model_state_json.hpp"
#include "cpgmatch/errors.hpp"
#include "cpgmatch/service/coordinator.hpp"

namespace cpgmatch::service {

namespace {

// The study's saved model state; nothing without a usable one (the optimizer is then rebuilt by replaying
// every report).
std::optional<bo::ModelState> saved_model_state(const study::StoredStudy* stored) {
  if (stored == nullptr || !stored->model_state.is_object()) return std::nullopt;
  try {
    bo::ModelState state = bo::model_state_from_json(stored->model_state);
    return state.observations >= 0 ? std::optional<bo::ModelState>(std::move(state)) : std::nullopt;
  } catch (const std::exception&) {
    return std::nullopt;
  }
}

// The saved lockstep proposal state (StudyRun::proposal_state), when there is a usable one.
std::optional<bo::ModelState> saved_proposal_state(const study::StoredStudy* stored) {
  if (stored == nullptr || !stored->model_state.is_object() || !stored->model_state.contains("proposal_state")) {
    return std::nullopt;
  }
  try {
    return bo::model_state_from_json(stored->model_state.at("proposal_state"));
  } catch (const std::exception&) {
    return std::nullopt;
  }
}

// The state to restore `n` observations from, when the store has one: the saved state itself; the state of
// its latest fit when `n` is that fit's count (the tells after it changed nothing but the count: they were
// the budget's last, which are never fitted); or a lockstep study's state at its latest ask, when it covers
// at most `n` (restore() tells the rest one refit each, which is how lockstep tells them: a lockstep
// optimizer after trials 0..n-1 is one and the same however it got there). Nothing: replay them all.
std::optional<bo::ModelState> state_at(const std::optional<bo::ModelState>& saved,
                                       const std::optional<bo::ModelState>& proposal, std::size_t n) {
  if (n == 0) return std::nullopt;
  if (saved && static_cast<std::size_t>(saved->observations) == n) return saved;
  if (saved && saved->fitted_observations >= 0 && static_cast<std::size_t>(saved->fitted_observations) == n) {
    bo::ModelState at_fit = *saved;
    at_fit.observations = saved->fitted_observations;
    return at_fit;
  }
  if (proposal && proposal->observations > 0 && static_cast<std::size_t>(proposal->observations) <= n) return proposal;
  return std::nullopt;
}

// What the optimizer was told for a stored trial: its cost, or a failure; and whether it fell.
bo::Observation stored_observation(const study::StoredTrial& t) {
  const std::optional<domain::RolloutReport> report = study::stored_report(t);
  const bool fell = t.ok && report && report->fell();
  // A trial spent on faults (its last report a plant fault or a divergence) was never in the model.
  const bool excluded = !t.ok && report && domain::reissued_not_spent(report->outcome);
  return bo::Observation{t.x, t.cost, !t.ok, fell, excluded};
}

// What a restart accounts for a stored trial: its report, or a failure when the stored one is unreadable.
domain::RolloutReport replayed_report(const study::StoredTrial& t, std::string* why) {
  if (auto report = study::stored_report(t, why)) return *report;
  domain::RolloutReport failed;
  failed.outcome = domain::Outcome::kError;
  failed.error = "stored report unreadable";
  return failed;
}

// The origin a migrated spec is stored with: which release resolved it, and why it had to.
std::string migrated_origin() {
  return fmt::format("migrated: the study was stored before specs existed; resolved at its first open from the "
                     "defaults this release ships, marked objective version {} (what releases before specs computed; "
                     "this release computes version {})",
                     study::kVersionBeforeSpecs, study::kObjectiveVersion);
}

}  // namespace

void Coordinator::resume_from_store(double now_s) {
  // A stored study this service cannot serve is still published, as it stands in the store: every client
  // (`status`, the dashboard) then lists the same studies, where before `status` left such a study out and a
  // dashboard that had seen it under the previous optimizer still showed it running (issue 34).
  auto show_unserved = [this](const study::StoredStudy& stored, StudyStatus status, const std::string& message) {
    domain::StudyState state;
    state.study_id = stored.study_id;
    state.name = stored.name;
    state.status = status;
    state.message = message;
    state.budget = static_cast<int>(stored.trials.size());
    state.completed = static_cast<int>(std::count_if(stored.trials.begin(), stored.trials.end(), [](const auto& t) {
      return t.status == study::TrialStatus::kDone;
    }));
    state.elapsed_s = std::max(0.0, wall_now() - stored.created_at_s);
    out_.publish_state(state);
  };
  for (const study::StoredStudy& stored : store_.load_all()) {
    StudyRun s;
    s.id = stored.study_id;
    s.name = stored.name;
    s.state = domain::study_status_from_string(stored.state).value_or(StudyStatus::kFailed);
    s.message = stored.message;
    if (!domain::study_status_from_string(stored.state)) s.message = fmt::format("unknown stored state '{}'", stored.state);
    s.created_at_s = stored.created_at_s;
    try {
      if (stored.spec.json.empty()) {
        // A store from before specs: the spec is the defaults of this release (same science), said so.
        auto spec = std::make_shared<const study::StudySpec>(
            study::StudySpec::resolve(stored.config_yaml, stored.source_name, spec_defaults(), study::kVersionBeforeSpecs));
        const study::StoredSpec migrated{spec->canonical_json(), spec->sha256(), migrated_origin()};
        store_.set_spec(s.id, migrated);
        info_(fmt::format("study {} '{}': stored before specs; spec {} resolved from this release's defaults", s.id,
                          s.name, spec->sha256().substr(0, 16)));
        s.spec = std::move(spec);
      } else {
        s.spec = std::make_shared<const study::StudySpec>(
            study::StudySpec::from_json_text(stored.spec.json, fmt::format("study {} spec", s.id)));
        if (s.spec->sha256() != stored.spec.sha256) {
          throw InputError(fmt::format("its stored spec hashes to {}, not to the stored {}", s.spec->sha256(),
                                       stored.spec.sha256));
        }
      }
      s.config = s.spec->config();
    } catch (const std::exception& e) {
      // Cannot happen for a study this service accepted, unless the file was edited by hand.
      // An open study is failed on record; a finished one keeps its stored state (its results stand: only
      // this release cannot re-derive its spec, e.g. a config folder missing here).
      const bool was_open = domain::is_open(s.state);
      warn_(fmt::format("study {} in {}: its configuration no longer loads ({}); {}", s.id, store_.path(), e.what(),
                        was_open ? "marked failed" : "left as stored"));
      if (was_open) store_.set_state(s.id, to_string(StudyStatus::kFailed), e.what());
      show_unserved(stored, was_open ? StudyStatus::kFailed : s.state, was_open ? e.what() : s.message);
      continue;
    }
    const int id = s.id;
    try {
      if (!stored.load_error.empty()) throw std::runtime_error(stored.load_error);
      open_study(std::move(s), &stored, now_s);
    } catch (const std::exception& e) {
      // One study that cannot be reopened (a corrupt row, a state this build cannot restore, memory) must
      // not take the rest of the store with it: mark it failed with the reason and serve the others.
      studies_.erase(id);
      warn_(fmt::format("study {} in {}: cannot be reopened ({}); marked failed", id, store_.path(), e.what()));
      store_.set_state(id, to_string(StudyStatus::kFailed), fmt::format("cannot be reopened: {}", e.what()));
      show_unserved(stored, StudyStatus::kFailed, fmt::format("cannot be reopened: {}", e.what()));
    }
  }
  if (!studies_.empty()) info_(fmt::format("resumed {} studies from {}", studies_.size(), store_.path()));
}

void Coordinator::open_study(StudyRun&& fresh, const study::StoredStudy* stored, double now_s) {
  const int id = fresh.id;
  auto [it, inserted] = studies_.emplace(id, std::move(fresh));
  StudyRun& s = it->second;
  std::vector<const study::StoredTrial*> done, validated, hardware;
  if (stored != nullptr) {
    for (const auto& t : stored->trials) {
      s.next_trial_id = std::max(s.next_trial_id, t.trial_id + 1);
      const bool validation = t.phase == "validation";
      const bool on_hardware = t.phase == "hardware";
      const bool enqueued = t.phase == study::kPhaseEnqueued;
      if (validation) s.validation_started = true;
      if (enqueued) s.enqueued_trials.insert(t.trial_id);
      if (t.status == study::TrialStatus::kDone) {
        (validation ? validated : on_hardware ? hardware : done).push_back(&t);
      } else {
        // Re-issued once a slot is free; the worker it last went to may still report that attempt. A
        // validation set or hardware proposal stored but never issued has no worker yet: it is issued, not
        // re-issued.
        InFlight f{t.x, t.attempt, "", 0.0, {}, validation, on_hardware};
        f.enqueued = enqueued;
        if (!t.worker_id.empty()) f.issued_to[t.attempt] = t.worker_id;
        s.in_flight[t.trial_id] = std::move(f);
      }
    }
  }
  // The optimizer was told the reports in the order they were counted, which with parallel workers is
  // not the trial order: replay them in that order (report_seq; stores older than it: report time).
  std::stable_sort(done.begin(), done.end(), [](const study::StoredTrial* a, const study::StoredTrial* b) {
    if (a->report_seq != b->report_seq) return a->report_seq < b->report_seq;
    return a->reported_at_s != b->reported_at_s ? a->reported_at_s < b->reported_at_s : a->trial_id < b->trial_id;
  });
  std::vector<bo::Observation> observations;
  const std::optional<bo::ModelState> saved = saved_model_state(stored);
  // Lockstep only (null otherwise); kept with every later state the study saves.
  const std::optional<bo::ModelState> proposal = s.config.lockstep > 0 ? saved_proposal_state(stored) : std::nullopt;
  if (proposal) s.proposal_state = stored->model_state.at("proposal_state");
  if (s.config.lockstep > 0) {
    // Lockstep: the optimizer holds trials 0..T-1 in trial order, T = what its saved state was fitted on;
    // the other reports wait in `untold` until an ask needs them, exactly as they would have. An open study
    // holds no more than its next proposal (trial next_trial_id) may see, trials 0..next-N-1: a finished
    // study's last job told every report, and once extended (cpgmatch study extend, which reopens it
    // running) it proposes on as if its budget had always been the larger one, its optimizer replayed up
    // to there. A finished one proposes nothing: it is restored whole (one factorisation, no replay).
    std::sort(done.begin(), done.end(),
              [](const study::StoredTrial* a, const study::StoredTrial* b) { return a->trial_id < b->trial_id; });
    const std::size_t may_see = s.is_open() ? static_cast<std::size_t>(std::max(0, s.next_trial_id - s.config.lockstep))
                                            : done.size();
    const std::size_t told = std::min(static_cast<std::size_t>(saved ? saved->observations : 0), may_see);
    for (const auto* t : done) {
      if (t->trial_id == static_cast<int>(observations.size()) && observations.size() < told) {
        observations.push_back(stored_observation(*t));
        s.told_trials.push_back(t->trial_id);
      } else {
        s.untold.emplace_back(t->trial_id, stored_observation(*t));
      }
    }
  } else {
    // The saved state covers the first reports counted; the ones after it were counted but not yet told
    // (their model job had not finished when the optimizer stopped). They wait in `untold` for the study's
    // next model job, which tells them as one batch off the event loop, as the uninterrupted run's next job
    // would have (a finished study too: its last reports get a job of their own). Telling them here, one
    // refit each, kept a restart on 1000 results from serving for 7-9 s.
    // Without a usable state (or one covering more reports than stored) every report is replayed.
    std::size_t told = saved && static_cast<std::size_t>(saved->observations) <= done.size()
                           ? static_cast<std::size_t>(saved->observations)
                           : done.size();
    // The state's last tells were not fitted (the budget's end: nobody would ask) and the budget is larger
    // now (an extended study): they wait for the next job, which fits them as the larger budget's run did.
    if (saved && saved->fitted_observations >= 0 && static_cast<std::size_t>(saved->fitted_observations) < told &&
        static_cast<int>(told) < s.config.budget) {
      told = static_cast<std::size_t>(saved->fitted_observations);
    }
    for (std::size_t i = 0; i < done.size(); ++i) {
      if (i < told) {
        observations.push_back(stored_observation(*done[i]));
        s.told_trials.push_back(done[i]->trial_id);
      } else {
        s.untold.emplace_back(done[i]->trial_id, stored_observation(*done[i]));
      }
    }
  }
  s.optimizer = std::make_shared<bo::BayesianOptimizer>(
      restored_optimizer(s, stored, state_at(saved, proposal, observations.size()), observations));
  s.model = ModelSnapshot::of(*s.optimizer, s.told_trials);
  // Hardware reports in the order they were counted, which is the order the hardware model was told them.
  std::stable_sort(hardware.begin(), hardware.end(), [](const study::StoredTrial* a, const study::StoredTrial* b) {
    return a->report_seq != b->report_seq ? a->report_seq < b->report_seq : a->trial_id < b->trial_id;
  });
  if (s.models_hardware()) restore_hardware_model(s, stored, observations, hardware);
  for (const auto* t : done) {
    const int trial_id = t->trial_id;
    std::string why;
    const domain::RolloutReport report = replayed_report(*t, &why);
    if (!why.empty()) {
      warn_(fmt::format("study {} trial {}: stored report unreadable ({}); counted as failed", id, trial_id, why));
    }
    s.account_report(trial_id, t->x, report);  // the optimizer already holds it: counters and best only
    // A finished study's records are served from the store (analyze, plot), not kept on the topic.
    if (s.is_open()) out_.publish_trial(s.trial_record(trial_id, t->x, report));
  }
  std::sort(validated.begin(), validated.end(),
            [](const study::StoredTrial* a, const study::StoredTrial* b) { return a->trial_id < b->trial_id; });
  for (const auto* t : validated) {
    const domain::RolloutReport report = replayed_report(*t, nullptr);
    s.account_validation(t->trial_id, report);
    if (s.is_open()) out_.publish_trial(s.trial_record(t->trial_id, t->x, report));
  }
  for (const auto* t : hardware) {
    const domain::RolloutReport report = replayed_report(*t, nullptr);
    // Counters only: restore_hardware_model() put each in the model or in hardware_untold.
    ++s.hardware_done;
    s.hardware_trials.push_back(t->trial_id);
    s.count_outcome(report);
    if (s.is_open()) out_.publish_trial(s.trial_record(t->trial_id, t->x, report));
  }
  s.records_retired = !s.is_open();
  if (s.is_open()) out_.publish_spec(s.spec_publication());  // before any of its candidates
  release_optimizer_if_done(s);
  s.session_start_s = now_s;
  s.completed_at_session_start = s.completed;
  if (!s.in_flight.empty()) {
    info_(fmt::format("study {} '{}': {} observations replayed, {} candidates in flight to re-issue", id, s.name,
                      s.completed, s.in_flight.size()));
  }
  finish_if_complete(s);
  s.dirty = true;
}

void Coordinator::restore_hardware_model(StudyRun& s, const study::StoredStudy* stored,
                                         const std::vector<bo::Observation>& simulated,
                                         const std::vector<const study::StoredTrial*>& hardware) {
  // The hardware model was told the simulated results in the optimizer's order (`simulated`, what the
  // optimizer holds now) and the hardware reports in the order counted. Its saved state covers the first k
  // and h of them (its last job told exactly those, then fitted): restored on those with one factorisation,
  // the rest wait for its next job, as they did in the uninterrupted run. Without a saved state it was never
  // told anything: everything waits.
  const bo::HardwareOptimizerOptions options = hardware_model_options(s.config);
  std::size_t k = 0, h = 0;
  std::optional<bo::HardwareModelState> state;
  if (stored != nullptr && stored->hardware_model_state.is_object()) {
    try {
      state = bo::hardware_model_state_from_json(stored->hardware_model_state);
      k = static_cast<std::size_t>(std::max(0, state->simulation_observations));
      h = static_cast<std::size_t>(std::max(0, state->hardware_observations));
      if (k > simulated.size() || h > hardware.size()) {
        throw InputError(fmt::format("it covers {} simulated and {} hardware results, the store holds {} and {}", k, h,
                                     simulated.size(), hardware.size()));
      }
    } catch (const std::exception& e) {
      warn_(fmt::format("study {}: saved hardware model state unusable ({}); telling every result again", s.id,
                        e.what()));
      state.reset();
      k = h = 0;
    }
  }
  std::vector<bo::Observation> sim_told(simulated.begin(), simulated.begin() + static_cast<std::ptrdiff_t>(k));
  std::vector<bo::Observation> hw_told;
  for (std::size_t i = 0; i < hardware.size(); ++i) {
    const bo::Observation o = stored_observation(*hardware[i]);
    if (i < h) {
      hw_told.push_back(o);
      s.hardware_told_trials.push_back(hardware[i]->trial_id);
    } else {
      s.hardware_untold.emplace_back(hardware[i]->trial_id, o);
    }
  }
  for (std::size_t i = k; i < simulated.size(); ++i) s.hardware_untold_sim.emplace_back(s.told_trials.at(i), simulated[i]);
  for (const auto& o : simulated) s.simulation_successes += o.failed ? 0 : 1;
  // Which of them were enqueued gaits, as the hardware model jobs told them (model_scheduler.cpp): the
  // store's phase says it, so the first robot rollout's point survives a restart.
  std::vector<bool> sim_enqueued;
  for (std::size_t i = 0; i < k; ++i) sim_enqueued.push_back(s.enqueued_trials.count(s.told_trials.at(i)) > 0);
  s.hardware_optimizer = std::make_shared<bo::HardwareOptimizer>(
      state ? bo::HardwareOptimizer::restore(s.config.space, options, sim_told, hw_told, *state, sim_enqueued)
            : bo::HardwareOptimizer(s.config.space, options));
  // Not stale after a restore (its fit counts are its observations): no fit here.
  s.hardware_model = ModelSnapshot::of(*s.hardware_optimizer, s.hardware_told_trials);
}

bo::BayesianOptimizer Coordinator::restored_optimizer(const StudyRun& s, const study::StoredStudy* stored,
                                                      const std::optional<bo::ModelState>& state,
                                                      const std::vector<bo::Observation>& observations) const {
  if (observations.empty()) return bo::BayesianOptimizer(s.config.space, s.config.optimizer);
  if (state) {
    try {
      return bo::BayesianOptimizer::restore(s.config.space, s.config.optimizer, observations, *state);
    } catch (const std::exception& e) {
      warn_(fmt::format("study {}: saved model state unusable ({}); replaying {} observations instead", s.id, e.what(),
                        observations.size()));
    }
  } else if (stored != nullptr && stored->model_state.is_object()) {
    info_(fmt::format("study {}: no saved model state for its first {} observations; replaying them", s.id,
                      observations.size()));
  } else {
    info_(fmt::format("study {}: no saved model state (older store); replaying {} observations", s.id,
                      observations.size()));
  }
  return bo::BayesianOptimizer::rebuild(s.config.space, s.config.optimizer, observations);
}

}  // namespace cpgmatch::service
