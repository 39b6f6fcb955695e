// The Coordinator's steering commands (issue 24, docs/steering.md), as Optuna users steer a study:
//
//  * extend (`cpgmatch study extend ID --budget N`): N more trials. The study's spec is re-resolved with the
//    larger budget (so it hashes as a study submitted with that budget would), stored, and the study is
//    reopened from the store exactly as a restart reopens it (coordinator_replay.cpp): same observations,
//    same saved model state, same random streams. The budget's last tells were never fitted (nobody would
//    ask); the reopened study fits them in its next model job, as the larger budget's run did.
//  * enqueue (`enqueue:` in a study file, `cpgmatch study enqueue ID --params F.yaml`): known gaits stored
//    at once as the study's next trials (phase "enqueued", no worker yet). The dispatcher issues them before
//    any proposal (stored trials without a worker go first), they count in the budget, and their reports
//    are told to the model like any exploration trial's.
#include <fmt/format.h>

#include "cpgmatch/service/coordinator.hpp"
#include "cpgmatch/service/enqueued_gaits.hpp"

namespace cpgmatch::service {

namespace {

// The largest budget a study file may give (study_config.cpp): an extension may not go past it either.
constexpr int kMaxBudget = 100'000;

}  // namespace

// ---- extend --------------------------------------------------------------------------------------

std::optional<std::string> Coordinator::extend_refusal(const domain::StudyCommand& command) {
  const StudyRun* s = find_study(command.study_id);
  if (s == nullptr) return fmt::format("no study {}", command.study_id);
  if (command.added_trials <= 0) {
    return fmt::format("extend: the trials to add must be > 0, got {}", command.added_trials);
  }
  if (s->state == StudyStatus::kFailed) {
    return fmt::format("study {} failed ({}): a failed study is not continued; submit its file again "
                       "(cpgmatch study show prints it)",
                       s->id, s->message);
  }
  if (s->config.validation.enabled || s->models_hardware()) {
    return fmt::format("study {} has a hardware phase ({}): extend continues studies without one (a validation "
                       "or hardware model phase follows the whole exploration; not built)",
                       s->id, study::to_string(s->config.hardware.strategy));
  }
  if (s->config.budget + static_cast<long>(command.added_trials) > kMaxBudget) {
    return fmt::format("study {}: a budget of {} + {} is more than a study may have ({})", s->id, s->config.budget,
                       command.added_trials, kMaxBudget);
  }
  return std::nullopt;
}

void Coordinator::extend_study(const domain::StudyCommand& command, double now_s) {
  StudyRun* s = find_study(command.study_id);
  if (s != nullptr && s->model_busy && !extend_refusal(command)) {
    // Its model job holds the optimizer (and will save its state): reopen once it has finished. A job of
    // the same key runs after it, and its completion is applied after that job's; meanwhile no new job
    // starts (reopening). A re-sent command while it waits gets the one reply.
    if (!resolving_.insert({command.client_id, command.correlation_id}).second) return;
    s->reopening = true;
    models_.run_aside(static_cast<std::uint64_t>(s->id), [this, command]() -> ModelPool::Completion {
      return [this, command] {
        resolving_.erase({command.client_id, command.correlation_id});
        if (StudyRun* waiting = find_study(command.study_id)) waiting->reopening = false;
        answer(command, [&](domain::CommandReply& reply) { extend_now(command, now_s_, reply); });
      };
    });
    return;
  }
  answer(command, [&](domain::CommandReply& reply) { extend_now(command, now_s, reply); });
}

void Coordinator::extend_now(const domain::StudyCommand& command, double now_s, domain::CommandReply& reply) {
  if (auto why = extend_refusal(command)) {
    reply.message = *why;
    return;
  }
  StudyRun& s = studies_.at(command.study_id);
  if (s.model_busy) {  // not after the wait above; said rather than risked
    reply.message = fmt::format("study {}: its model is busy; send the command again", s.id);
    return;
  }
  const int id = s.id;
  const int before = s.config.budget, after = before + command.added_trials;
  auto spec = std::make_shared<const study::StudySpec>(with_budget(*s.spec, after));
  store_.set_spec(id, study::StoredSpec{spec->canonical_json(), spec->sha256(),
                                        fmt::format("extended: budget {} -> {} (spec {} before)", before, after,
                                                    s.spec->sha256())});
  // Stopped or done: running again. Running or paused: as it was, with the larger budget.
  const StudyStatus state = s.is_open() ? s.state : StudyStatus::kRunning;
  store_.set_state(id, to_string(state), "");
  // The old spec leaves the topic (unless another open study runs it); the reopened study publishes its own.
  const bool shared = std::any_of(studies_.begin(), studies_.end(), [&](const auto& kv) {
    return kv.second.id != id && kv.second.is_open() && kv.second.spec && kv.second.spec->key() == s.spec->key();
  });
  if (!s.records_retired && !shared) out_.retire_spec(s.spec_publication());

  StudyRun old = std::move(s);
  studies_.erase(id);
  const std::optional<study::StoredStudy> stored = store_.load(id);
  if (!stored) throw std::runtime_error(fmt::format("study {} vanished from the store", id));
  StudyRun fresh;
  fresh.id = id;
  fresh.name = old.name;
  fresh.state = state;
  fresh.created_at_s = old.created_at_s;
  fresh.spec = spec;
  fresh.config = spec->config();
  open_study(std::move(fresh), &*stored, now_s);
  // A restart re-issues what was in flight; this service still knows who runs it: the assignments stay.
  StudyRun& reopened = studies_.at(id);
  for (auto& [trial_id, f] : old.in_flight) {
    if (reopened.in_flight.count(trial_id) > 0) reopened.in_flight[trial_id] = std::move(f);
  }
  reopened.reissued = old.reissued;
  reopened.refused_by = std::move(old.refused_by);
  reopened.dirty = true;
  publish_state(reopened, now_s);
  reply.ok = true;
  reply.message = fmt::format("study {} '{}' extended by {} trials: budget {} -> {}, {} done, {} (spec {})", id,
                              reopened.name, command.added_trials, before, after, reopened.completed,
                              to_string(reopened.state), spec->sha256().substr(0, 16));
  info_(reply.message);
}

// ---- enqueue -------------------------------------------------------------------------------------

std::optional<std::string> Coordinator::enqueue_refusal(const study::StudySpec& spec,
                                                        const std::vector<domain::EnqueuedGait>& gaits, int room,
                                                        std::vector<Eigen::VectorXd>& points) {
  if (static_cast<int>(gaits.size()) > room) {
    return fmt::format("{} gaits to enqueue, and room for {} more trials in the budget of {} (enqueued trials "
                       "count in the budget: extend the study first)",
                       gaits.size(), room, spec.config().budget);
  }
  points.clear();
  for (const auto& gait : gaits) {
    try {
      points.push_back(point_of_gait(spec, gait));
    } catch (const std::exception& e) {
      return std::string(e.what());
    }
  }
  return std::nullopt;
}

void Coordinator::enqueue_command(const domain::StudyCommand& command, domain::CommandReply& reply) {
  StudyRun* s = find_study(command.study_id);
  if (s == nullptr) {
    reply.message = fmt::format("no study {}", command.study_id);
    return;
  }
  if (command.enqueue.empty()) {
    reply.message = fmt::format("study {}: no gait to enqueue", s->id);
    return;
  }
  if (s->state == StudyStatus::kDone || s->state == StudyStatus::kFailed) {
    reply.message = fmt::format("study {} is {}: {}", s->id, to_string(s->state),
                                s->state == StudyStatus::kDone
                                    ? fmt::format("extend it first (cpgmatch study extend {} --budget N), then enqueue", s->id)
                                    : std::string("a failed study runs nothing more"));
    return;
  }
  if (s->validation_started) {
    reply.message = fmt::format("study {}: its exploration is over (validation phase)", s->id);
    return;
  }
  const int room = s->config.budget - s->completed - s->exploring_in_flight();
  std::vector<Eigen::VectorXd> points;
  if (auto why = enqueue_refusal(*s->spec, command.enqueue, room, points)) {
    reply.message = fmt::format("study {}: {}", s->id, *why);
    return;
  }
  const std::vector<int> trials = enqueue_points(*s, points, command.enqueue);
  std::string which;
  for (std::size_t i = 0; i < trials.size(); ++i) {
    which += fmt::format("{}{} ({})", i == 0 ? "" : ", ", trials[i], command.enqueue[i].source);
  }
  reply.ok = true;
  reply.message = fmt::format("study {}: queued as trial {}; {}", s->id, which,
                              s->state == StudyStatus::kStopped
                                  ? "the study is stopped: they run once it is extended (cpgmatch study extend)"
                                  : "they run before its next proposal");
  info_(reply.message);
}

std::vector<int> Coordinator::enqueue_points(StudyRun& s, const std::vector<Eigen::VectorXd>& points,
                                             const std::vector<domain::EnqueuedGait>& gaits) {
  std::vector<study::StoredTrial> stored;
  for (const auto& x : points) {
    study::StoredTrial t;
    t.trial_id = s.next_trial_id++;
    t.x = x;
    t.issued_at_s = wall_now();
    t.phase = study::kPhaseEnqueued;
    stored.push_back(std::move(t));
  }
  if (stored.empty()) return {};
  store_.add_trials(s.id, stored);  // before anything of them is published
  std::vector<int> ids;
  for (std::size_t i = 0; i < stored.size(); ++i) {
    InFlight f{stored[i].x, 0, "", 0.0, {}};
    f.enqueued = true;
    s.in_flight[stored[i].trial_id] = std::move(f);
    s.enqueued_trials.insert(stored[i].trial_id);
    ids.push_back(stored[i].trial_id);
    info_(fmt::format("study {} trial {}: enqueued gait from {}", s.id, stored[i].trial_id, gaits.at(i).source));
  }
  // Points proposed before took trial ids for granted (lockstep numbers its asks by them): proposed again.
  s.proposed.clear();
  ++s.proposal_epoch;
  s.dirty = true;
  return ids;
}

}  // namespace cpgmatch::service
