#include "cpgmatch/service/model_scheduler.hpp"

#include <algorithm>
#include <set>

#include <fmt/format.h>

#include "cpgmatch/bo/model_state_json.hpp"

namespace cpgmatch::service {

namespace {

// The fitted model as the event thread keeps it and the store saves it.
std::pair<ModelSnapshot, nlohmann::json> fitted_model(const bo::BayesianOptimizer& optimizer,
                                                      const std::vector<int>& told_trials) {
  return {ModelSnapshot::of(optimizer, told_trials), bo::model_state_to_json(optimizer.model_state())};
}

}  // namespace

// ---- asynchronous ------------------------------------------------------------------------------

std::optional<ModelWork> AsynchronousModel::prepare(StudyRun& s, int ask, const std::function<void(int)>& hook,
                                                    std::string&) const {
  // Everything the job needs is copied now: it runs while the event thread goes on changing the study.
  std::vector<bo::Observation> tells;
  for (auto& [trial_id, observation] : s.untold) {
    s.told_trials.push_back(trial_id);  // the order the optimizer will hold them in
    if (s.hardware_optimizer) {
      // The hardware model learns the simulated results in the order the optimizer does (a restart
      // rebuilds both from that order), at its own next job.
      s.hardware_untold_sim.emplace_back(trial_id, observation);
      if (!observation.failed) ++s.simulation_successes;
    }
    tells.push_back(std::move(observation));
  }
  s.untold.clear();
  std::vector<Eigen::VectorXd> pending;  // points being evaluated or about to be: the liar's lies
  for (const auto& [trial_id, f] : s.in_flight) pending.push_back(f.x);
  pending.insert(pending.end(), s.proposed.begin(), s.proposed.end());
  const int id = s.id;
  return [id, hook, optimizer = s.optimizer, told_trials = s.told_trials, tells = std::move(tells),
          pending = std::move(pending), ask]() -> ModelJobResult {
    if (hook) hook(id);
    ModelJobResult result;
    result.study_id = id;
    result.ask = ask;
    try {
      if (!tells.empty()) {
        optimizer->tell_batch(tells);  // one fit for every report since the last job
        result.fitted = fitted_model(*optimizer, told_trials);
      }
      if (ask > 0) result.points = optimizer->ask(ask, pending);
    } catch (const std::exception& e) {
      result.error = e.what();  // e.g. a GP that cannot be factorised: logged, and the study asks again next tick
    }
    return result;
  };
}

// ---- lockstep ----------------------------------------------------------------------------------

int LockstepModel::tellable(const StudyRun& s) {
  std::set<int> reported;
  for (const auto& [trial_id, observation] : s.untold) reported.insert(trial_id);
  int next = static_cast<int>(s.told_trials.size());
  while (reported.count(next) > 0) ++next;
  return next - static_cast<int>(s.told_trials.size());
}

int LockstepModel::room(const StudyRun& s) {
  // Trial k may be proposed once trials 0..k-N-1 have reported.
  const int next_to_propose = s.next_trial_id + static_cast<int>(s.proposed.size());
  const int reported_prefix = static_cast<int>(s.told_trials.size()) + tellable(s);
  return std::max(0, reported_prefix + s.config.lockstep - next_to_propose);
}

bool LockstepModel::worth_a_job(const StudyRun& s, int ask) const {
  if (ask > 0) return true;
  // Telling early would change later proposals: reports wait for the ask that needs them, or for the end of
  // the exploration (every trial proposed), when they are all told. A paused study waits too.
  const bool all_proposed = s.next_trial_id + static_cast<int>(s.proposed.size()) >= s.config.budget;
  return all_proposed && tellable(s) > 0;
}

std::optional<ModelWork> LockstepModel::prepare(StudyRun& s, int ask, const std::function<void(int)>& hook,
                                                std::string& why) const {
  const int lag = s.config.lockstep;
  const int told0 = static_cast<int>(s.told_trials.size());
  const int k0 = s.next_trial_id + static_cast<int>(s.proposed.size());
  // The points of trials told0..k0-1: reported and waiting, in flight, or proposed and not yet issued.
  std::map<int, bo::Observation> reported(s.untold.begin(), s.untold.end());
  std::vector<Eigen::VectorXd> xs;
  for (int id = told0; id < k0; ++id) {
    if (const auto r = reported.find(id); r != reported.end()) {
      xs.push_back(r->second.x);
    } else if (const auto f = s.in_flight.find(id); f != s.in_flight.end()) {
      xs.push_back(f->second.x);
    } else if (id >= s.next_trial_id) {
      xs.push_back(s.proposed[static_cast<std::size_t>(id - s.next_trial_id)]);
    } else {
      why = fmt::format("lockstep: trial {} has no point; asking nothing this time", id);
      return std::nullopt;
    }
  }
  // Tells: what the last ask needs (trials up to k_last - N - 1), and at the end every reported trial.
  const bool final_asks = k0 + ask >= s.config.budget;
  const int can_tell = tellable(s);
  const int needed = ask > 0 ? std::max(0, k0 + ask - 1 - lag - told0) : 0;
  const int tells_count = final_asks ? can_tell : std::min(needed, can_tell);
  std::vector<bo::Observation> tells;
  for (int i = 0; i < tells_count; ++i) {
    tells.push_back(reported.at(told0 + i));
    s.told_trials.push_back(told0 + i);
  }
  s.untold.erase(std::remove_if(s.untold.begin(), s.untold.end(),
                                [&](const auto& kv) { return kv.first < told0 + tells_count; }),
                 s.untold.end());
  const int id = s.id;
  return [id, hook, optimizer = s.optimizer, told_trials = s.told_trials, tells = std::move(tells),
          xs = std::move(xs), ask, lag, told0, k0]() mutable -> ModelJobResult {
    if (hook) hook(id);
    ModelJobResult result;
    result.study_id = id;
    result.ask = ask;
    try {
      int told = told0;
      auto tell_next = [&] { optimizer->tell_batch({tells[static_cast<std::size_t>(told++ - told0)]}); };
      for (int k = k0; k < k0 + ask; ++k) {
        while (told < k - lag) tell_next();  // exactly trials 0..k-N-1, one fit each, in trial order
        std::vector<Eigen::VectorXd> pending(xs.begin() + (told - told0), xs.end());  // trials told..k-1
        const Eigen::VectorXd x = optimizer->ask(1, pending).front();
        result.points.push_back(x);
        xs.push_back(x);
      }
      // The state its last proposal saw: the jobs after the exploration's last ask tell every report beyond it.
      if (ask > 0) result.proposal_state = bo::model_state_to_json(optimizer->model_state());
      while (told < told0 + static_cast<int>(tells.size())) tell_next();
      if (!tells.empty()) result.fitted = fitted_model(*optimizer, told_trials);
    } catch (const std::exception& e) {
      result.error = e.what();
    }
    return result;
  };
}

const ModelStrategy& strategy_for(const StudyRun& study) {
  static const AsynchronousModel asynchronous;
  static const LockstepModel lockstep;
  return study.config.lockstep > 0 ? static_cast<const ModelStrategy&>(lockstep) : asynchronous;
}

// ---- the hardware model ------------------------------------------------------------------------

std::optional<HardwareModelJob::Kind> HardwareModelJob::due(const StudyRun& s, int usable_hardware_slots) {
  if (!s.hardware_optimizer || s.state != StudyStatus::kRunning) return std::nullopt;
  const bool point_waits = std::any_of(s.in_flight.begin(), s.in_flight.end(), [](const auto& kv) {
    return kv.second.hardware && kv.second.worker_id.empty();
  });
  if (usable_hardware_slots > 0 && s.hardware_to_propose() > 0 && !point_waits &&
      static_cast<int>(s.told_trials.size()) >= s.config.hardware.start_after && s.simulation_successes >= 2) {
    return Kind::kAsk;
  }
  if (!s.hardware_untold.empty()) return Kind::kTell;
  const bool nothing_left_to_run = s.completed >= s.config.budget && s.in_flight.empty() && s.untold.empty() &&
                                   s.hardware_to_propose() == 0;
  if (nothing_left_to_run && !s.hardware_untold_sim.empty()) return Kind::kTell;
  return std::nullopt;
}

ModelWork HardwareModelJob::prepare(StudyRun& s, Kind kind, const std::function<void(int)>& hook) {
  std::vector<bo::Observation> simulated, hardware;
  // Which simulated results are enqueued gaits: the best of them is the first robot rollout
  // (bo::HardwareOptimizer::start_point). Enqueued gaits run on simulation workers like any exploration
  // trial and are told in the same order; one enqueued after the first robot rollout changes nothing
  // (only the first rollout starts from it), and one still running then is not waited for.
  std::vector<bool> enqueued;
  for (auto& [trial_id, observation] : s.hardware_untold_sim) {
    simulated.push_back(std::move(observation));
    enqueued.push_back(s.enqueued_trials.count(trial_id) > 0);
  }
  for (auto& [trial_id, observation] : s.hardware_untold) {
    s.hardware_told_trials.push_back(trial_id);
    hardware.push_back(std::move(observation));
  }
  s.hardware_untold_sim.clear();
  s.hardware_untold.clear();
  std::vector<Eigen::VectorXd> pending;  // hardware points on (or waiting for) a robot
  for (const auto& [trial_id, f] : s.in_flight) {
    if (f.hardware) pending.push_back(f.x);
  }
  const int id = s.id;
  const bool ask = kind == Kind::kAsk;
  return [id, hook, model = s.hardware_optimizer, told = s.hardware_told_trials, simulated = std::move(simulated),
          enqueued = std::move(enqueued), hardware = std::move(hardware), pending = std::move(pending),
          ask]() -> ModelJobResult {
    if (hook) hook(id);
    ModelJobResult result;
    result.study_id = id;
    result.ask = ask ? 1 : 0;
    result.hardware = true;
    try {
      for (std::size_t i = 0; i < simulated.size(); ++i) model->tell_simulation(simulated[i], enqueued[i]);
      for (const auto& o : hardware) model->tell_hardware(o);
      if (ask) result.hardware_point = model->ask(pending);  // fits the model when its data changed
      // The answer from the same fit (a tell-only job fits here), and the state a restart resumes from.
      ModelSnapshot answer = ModelSnapshot::of(*model, told);
      result.hardware_fitted.emplace(std::move(answer), bo::hardware_model_state_to_json(model->model_state()));
    } catch (const std::exception& e) {
      result.error = e.what();
    }
    return result;
  };
}

// ---- the scheduler -----------------------------------------------------------------------------

ModelScheduler::ModelScheduler(ModelSchedulerOptions options, std::function<void(ModelJobResult)> apply,
                               std::function<void(const std::string&)> warn)
    : options_(std::move(options)),
      apply_(std::move(apply)),
      warn_(std::move(warn)),
      pool_(options_.threads, options_.on_result) {}

void ModelScheduler::start_jobs(std::map<int, StudyRun>& studies, const std::vector<StudyRun*>& order,
                                int free_simulation, int free_hardware,
                                const std::function<int(const StudyRun&)>& hardware_slots_for) {
  // Slots that a job already running will fill are not asked for twice; each study asks only for slots
  // of the kind its exploration runs on. Points already proposed and waiting for a slot (the issue cap held
  // them back) will fill free slots too.
  int wanted[2] = {free_simulation, free_hardware};
  for (const auto& [id, s] : studies) {
    wanted[s.explores_on_hardware()] -=
        s.asking + (s.state == StudyStatus::kRunning ? static_cast<int>(s.proposed.size()) : 0);
  }
  int new_budget = options_.max_new_points_per_tick;  // points asked for this tick, over all studies
  for (StudyRun* s : order) {
    if (s->model_busy || s->reopening || !s->optimizer) continue;
    if (s->hardware_optimizer) {
      const int usable = std::min(wanted[1], hardware_slots_for(*s));
      if (const auto kind = HardwareModelJob::due(*s, usable)) {
        if (*kind == HardwareModelJob::Kind::kAsk) --wanted[1];
        s->model_busy = true;
        submit(*s, HardwareModelJob::prepare(*s, *kind, options_.job_hook));
        continue;  // its simulation job, if one is due, at the next tick
      }
    }
    int n = 0;
    int& wanted_here = wanted[s->explores_on_hardware()];
    if (s->state == StudyStatus::kRunning) {
      const int remaining =
          s->config.budget - s->completed - s->exploring_in_flight() - static_cast<int>(s->proposed.size());
      n = std::max(0, std::min({remaining, wanted_here, new_budget}));
    }
    const ModelStrategy& strategy = strategy_for(*s);
    n = strategy.allowed(*s, n);
    if (!strategy.worth_a_job(*s, n)) continue;
    wanted_here -= n;
    new_budget -= n;
    start_job(studies, *s, n);
  }
}

void ModelScheduler::start_job(std::map<int, StudyRun>& studies, StudyRun& s, int ask) {
  std::string why;
  std::optional<ModelWork> work = strategy_for(s).prepare(s, ask, options_.job_hook, why);
  if (!work) {
    warn_(fmt::format("study {}: {}", s.id, why));
    return;
  }
  // A job's acquisition search spreads over more threads only when fewer studies have jobs than there are
  // model threads (one study on two cores, say); otherwise the other studies' jobs fill the cores anyway,
  // and helper threads would only compete with them. Safe here: no job of this study is running.
  const int busy = static_cast<int>(
      std::count_if(studies.begin(), studies.end(), [](const auto& kv) { return kv.second.model_busy; }));
  s.optimizer->set_threads(busy + 1 < std::max(options_.threads, 1) ? options_.acquisition_threads : 1);
  s.model_busy = true;
  s.asking = ask;
  submit(s, [work = std::move(*work), epoch = s.proposal_epoch]() {
    ModelJobResult result = work();
    result.epoch = epoch;
    return result;
  });
}

void ModelScheduler::submit(StudyRun& s, ModelWork work) {
  pool_.submit(static_cast<std::uint64_t>(s.id), [work = std::move(work), this]() -> ModelPool::Completion {
    // On the model thread: the model work. Its result is applied on the event thread.
    return [result = work(), this]() mutable { apply_(std::move(result)); };
  });
}

}  // namespace cpgmatch::service
