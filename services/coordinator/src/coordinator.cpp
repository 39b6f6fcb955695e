// The Coordinator's live half: commands, reports, workers, the validation phase and the tick. Restart is in
// coordinator_replay.cpp; the parts it delegates to are StudyRun, Dispatcher, ModelScheduler, WorkerPool and
// ReplyCache.
#include "cpgmatch/service/coordinator.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <optional>
#include <vector>

#include <fmt/format.h>

#include "cpgmatch/domain/worker_identity.hpp"
#include "cpgmatch/service/validation_sets.hpp"

namespace cpgmatch::service {

namespace {

// A study state sample at most this often while nothing terminal happens (a busy study would
// otherwise publish one per report).
constexpr double kStatePublishPeriod_s = 0.1;

}  // namespace

Coordinator::Coordinator(study::StudyStore& store, Outbox& outbox, CoordinatorOptions options, LogFn log_info,
                         LogFn log_warning)
    : store_(store),
      out_(outbox),
      options_(std::move(options)),
      info_(std::move(log_info)),
      warn_(std::move(log_warning)),
      dispatcher_(store_, out_, pool_, [this] { return wall_now(); }),
      models_(ModelSchedulerOptions{options_.model_threads, options_.acquisition_threads,
                                    options_.max_new_candidates_per_tick, options_.on_model_result,
                                    options_.model_job_hook},
              [this](ModelJobResult result) { apply_model_result(std::move(result)); }, warn_) {}

void Coordinator::reject(const std::string& what, const std::string& why) {
  ++rejected_;
  warn_(fmt::format("rejected {}: {}", what, why));
}

std::optional<std::string> Coordinator::identity_refusal(const std::string& worker_id,
                                                         const std::optional<std::string>& sender_identity) const {
  if (!options_.require_authenticated_workers) return std::nullopt;
  if (!sender_identity || sender_identity->empty()) {
    return std::string("DDS-Security is on and the sender's certificate is not known (no authenticated identity "
                       "for its participant)");
  }
  if (!domain::worker_id_belongs_to(worker_id, *sender_identity)) {
    return fmt::format("the sender's certificate is CN={}, which does not own worker id '{}' (a worker id must be "
                       "its certificate's CN, or CN/suffix)",
                       *sender_identity, worker_id);
  }
  return std::nullopt;
}

StudyRun* Coordinator::find_study(int study_id) {
  const auto it = studies_.find(study_id);
  return it == studies_.end() ? nullptr : &it->second;
}

bool Coordinator::idle() const {
  for (const auto& [id, s] : studies_) {
    if (s.state == StudyStatus::kRunning || !s.in_flight.empty()) return false;
  }
  return true;
}

// ---- studies -------------------------------------------------------------------------------------

int Coordinator::points_waiting(int study_id) const {
  const auto s = studies_.find(study_id);
  return s == studies_.end() ? 0 : static_cast<int>(s->second.proposed.size());
}

double Coordinator::wall_now() const {
  if (options_.wall_clock_s) return options_.wall_clock_s();
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}




namespace {

std::string source_of(const domain::StudyCommand& command) {
  return !command.source_name.empty() ? command.source_name : "submitted study";
}

// A submitted study file's spec, resolved onto the defaults; or why it cannot be.
ResolvedSubmission resolve_submission(const domain::StudyCommand& command, const study::SpecDefaults& defaults) {
  ResolvedSubmission resolved;
  try {
    resolved.spec = std::make_shared<const study::StudySpec>(
        study::StudySpec::resolve(command.study_yaml, source_of(command), defaults));
  } catch (const std::exception& e) {
    resolved.error = e.what();
  }
  return resolved;
}

}  // namespace

std::optional<std::string> Coordinator::oversized(const domain::StudyCommand& command) const {
  if (command.study_yaml.size() <= study::kMaxStudyFileBytes) return std::nullopt;
  // Refused before any parsing: a 12 MB file of 700k keys took the service to 800 MB and stalled its
  // event loop for 2.5 s (a healthy worker was declared silent meanwhile).
  return fmt::format("{}: {} bytes, more than a study file may have ({} bytes)", source_of(command),
                     command.study_yaml.size(), study::kMaxStudyFileBytes);
}

void Coordinator::accept_submission(const domain::StudyCommand& command, const ResolvedSubmission& resolved,
                                    double now_s, domain::CommandReply& reply) {
  if (!resolved.spec) {
    reply.ok = false;
    reply.message = resolved.error;
    warn_(fmt::format("submit from {} refused: {}", command.client_id, resolved.error));
    return;
  }
  const auto& spec = resolved.spec;
  std::vector<Eigen::VectorXd> queued;  // the study file's enqueue gaits, checked before anything is stored
  if (auto why = enqueue_refusal(*spec, command.enqueue, spec->config().budget, queued)) {
    reply.ok = false;
    reply.message = *why;
    warn_(fmt::format("submit from {} refused: {}", command.client_id, *why));
    return;
  }
  StudyRun s;
  s.spec = spec;
  s.config = spec->config();
  s.name = s.config.name;
  s.created_at_s = wall_now();
  s.id = store_.create_study(s.name, command.study_yaml, source_of(command), s.created_at_s,
                             study::StoredSpec{spec->canonical_json(), spec->sha256(), study::kOriginSubmitted});
  const int id = s.id;
  info_(fmt::format("study {} '{}' submitted: budget {}, {} parameters", id, s.name, s.config.budget,
                    s.config.space.size()));
  try {
    open_study(std::move(s), nullptr, now_s);
  } catch (const study::StoreWriteError&) {
    throw;
  } catch (const std::exception& e) {
    // Refused after it was stored (the spec's checks at resolve should have caught it): failed on record and
    // in every client's view, never left "running" with nothing to run (issue 34).
    studies_.erase(id);
    store_.set_state(id, to_string(StudyStatus::kFailed), e.what());
    domain::StudyState failed;
    failed.study_id = id;
    failed.name = spec->config().name;
    failed.status = StudyStatus::kFailed;
    failed.message = e.what();
    failed.budget = spec->config().budget;
    out_.publish_state(failed);
    throw;
  }
  enqueue_points(studies_.at(id), queued, command.enqueue);
  reply.ok = true;
  reply.study_id = id;
  reply.message = fmt::format("study {} '{}' accepted (spec {})", id, studies_.at(id).name, spec->sha256().substr(0, 16));
}

void Coordinator::resolve_off_thread(const domain::StudyCommand& command) {
  // A re-sent submit whose spec is still being resolved: its one reply comes when it is.
  if (!resolving_.insert({command.client_id, command.correlation_id}).second) return;
  // Keys above every study id: a submit's job never waits behind a study's model job, and two submits
  // resolve in parallel.
  const std::uint64_t key = (std::uint64_t{1} << 63) | next_submit_job_++;
  models_.run_aside(key, [this, command, defaults = spec_defaults()]() -> ModelPool::Completion {
    ResolvedSubmission resolved = resolve_submission(command, defaults);  // on a model thread
    return [this, command, resolved = std::move(resolved)] {
      resolving_.erase({command.client_id, command.correlation_id});
      answer(command, [&](domain::CommandReply& reply) { accept_submission(command, resolved, now_s_, reply); });
    };
  });
}

void Coordinator::handle_command(const domain::StudyCommand& command, double now_s) {
  now_s_ = now_s;
  if (const auto done = replies_.find(command)) {
    out_.reply(*done);  // a re-sent command: same answer, not a second execution
    return;
  }
  if (command.kind == domain::CommandKind::kExtend) return extend_study(command, now_s);
  if (command.kind == domain::CommandKind::kEnqueue) {
    return answer(command, [&](domain::CommandReply& reply) { enqueue_command(command, reply); });
  }
  if (command.kind == domain::CommandKind::kSubmit) {
    if (const auto too_big = oversized(command)) {
      return answer(command, [&](domain::CommandReply& reply) {
        reply.message = *too_big;
        warn_(fmt::format("submit from {} refused: {}", command.client_id, *too_big));
      });
    }
    if (options_.resolve_specs_off_thread) return resolve_off_thread(command);
    return answer(command, [&](domain::CommandReply& reply) {
      accept_submission(command, resolve_submission(command, spec_defaults()), now_s, reply);
    });
  }
  answer(command, [&](domain::CommandReply& reply) {
    StudyRun* s = find_study(command.study_id);
    if (s == nullptr) {
      reply.message = fmt::format("no study {}", command.study_id);
      return;
    }
    const StudyStatus wanted = command.kind == domain::CommandKind::kPause    ? StudyStatus::kPaused
                               : command.kind == domain::CommandKind::kResume ? StudyStatus::kRunning
                                                                              : StudyStatus::kStopped;
    std::optional<StudyStatus> target;
    if (wanted == StudyStatus::kPaused && s->state == StudyStatus::kRunning) target = wanted;
    if (wanted == StudyStatus::kRunning && s->state == StudyStatus::kPaused) target = wanted;
    if (wanted == StudyStatus::kStopped && s->is_open()) target = wanted;
    if (!target) {
      reply.message = fmt::format("study {} is {}: nothing to do", s->id, to_string(s->state));
      reply.ok = s->state == wanted;
    } else {
      store_.set_state(s->id, to_string(*target), "");
      s->state = *target;
      s->dirty = true;
      reply.ok = true;
      reply.message = fmt::format("study {} is {}", s->id, to_string(*target));
      info_(reply.message);
      publish_state(*s, now_s);
    }
  });
}

void Coordinator::answer(const domain::StudyCommand& command, const std::function<void(domain::CommandReply&)>& execute) {
  domain::CommandReply reply;
  reply.correlation_id = command.correlation_id;
  reply.client_id = command.client_id;
  reply.study_id = command.study_id;
  reply.ok = false;
  try {
    execute(reply);
  } catch (const study::StoreWriteError& e) {
    // The store cannot record the command's effect: tell the client why, then stop the service (the
    // caller sees the same error) rather than go on acknowledging what it cannot record.
    reply.ok = false;
    reply.message = e.what();
    out_.reply(reply);
    throw;
  } catch (const std::exception& e) {
    reply.ok = false;
    reply.message = fmt::format("internal error: {}", e.what());
    warn_(reply.message);
  }
  if (!reply.ok && command.kind != domain::CommandKind::kSubmit) {
    warn_(fmt::format("command from {} refused: {}", command.client_id, reply.message));
  }
  replies_.remember(command, reply);
  out_.reply(reply);
}

// ---- workers -------------------------------------------------------------------------------------

void Coordinator::handle_worker(const domain::WorkerAnnouncement& w, double now_s,
                                const std::optional<std::string>& sender_identity) {
  const std::string id = w.worker_id;
  if (id.empty()) return reject("worker announcement", "empty worker_id");
  if (w.worker_key != domain::worker_key(id)) return reject("worker announcement " + id, "worker_key is not the hash of worker_id");
  // Before anything of it is taken: a participant that may not speak for `id` neither joins it nor keeps
  // it alive (its heartbeats would hide the real worker's silence).
  if (auto why = identity_refusal(id, sender_identity)) return reject("worker announcement " + id, *why);
  if (w.slots < 1 || w.slots > 4096) return reject("worker announcement " + id, fmt::format("slots = {}", w.slots));
  const AnnouncementEffect effect =
      pool_.announce(id, w.worker_key, w.slots, w.kind == domain::WorkerKind::kHardware, w.accepting,
                     w.status, now_s);
  if (effect.accepts_again) {
    // Accepting again (an emergency stop released): its refusals no longer hold.
    for (auto& [sid, s] : studies_) s.refused_by.erase(id);
  }
  if (effect.joined) {
    info_(fmt::format("worker {} joined: {} slots, {} on {}", id, w.slots, domain::to_string(w.kind), w.host));
  }
  if (effect.joined || effect.availability_changed) {
    for (auto& [sid, s] : studies_) s.dirty = true;
  }
}

void Coordinator::handle_worker_gone(std::uint64_t worker_key, double now_s, WorkerExit exit,
                                     const std::optional<std::string>& disposed_by) {
  const PoolWorker* w = pool_.by_key(worker_key);
  if (w == nullptr) return;
  const std::string id = w->id;
  if (disposed_by) {
    if (auto why = identity_refusal(id, disposed_by)) return reject("dispose of worker " + id, *why);
  }
  drop_worker(id,
              exit == WorkerExit::kLeft ? "left: it shut down cleanly"
                                        : "lost: its writers vanished without a goodbye (crashed, killed or cut off)",
              now_s);
}

void Coordinator::unassign(StudyRun& study, int trial_id, const std::string& why) {
  auto it = study.in_flight.find(trial_id);
  if (it == study.in_flight.end() || it->second.worker_id.empty()) return;
  info_(fmt::format("study {} trial {}: re-issuing ({} from {})", study.id, trial_id, why, it->second.worker_id));
  it->second.worker_id.clear();
  ++study.reissued;
  study.dirty = true;
}

void Coordinator::drop_worker(const std::string& worker_id, const std::string& why, double) {
  if (pool_.find(worker_id) == nullptr) return;
  const auto assigned = pool_.remove(worker_id);
  info_(fmt::format("worker {} {} with {} candidates assigned", worker_id, why, assigned.size()));
  for (const auto& [study_id, trial_id] : assigned) {
    if (StudyRun* s = find_study(study_id)) unassign(*s, trial_id, "worker " + why);
  }
  for (auto& [sid, s] : studies_) s.dirty = true;
}

// ---- candidates ----------------------------------------------------------------------------------



std::vector<StudyRun*> Coordinator::round_robin_order() {
  std::vector<StudyRun*> order;
  for (auto& [id, s] : studies_) order.push_back(&s);
  if (order.empty()) return order;
  std::rotate(order.begin(), order.begin() + (round_robin_++ % static_cast<int>(order.size())), order.end());
  return order;
}


void Coordinator::fail_on_failure_streak(StudyRun& s, const domain::RolloutReport& r) {
  if (s.state != StudyStatus::kRunning || s.consecutive_failures < options_.max_consecutive_failures) return;
  s.state = StudyStatus::kFailed;
  s.message = fmt::format("{} rollouts in a row could not run; last error: {}", s.consecutive_failures,
                          r.error);
  store_.set_state(s.id, to_string(s.state), s.message);
  warn_(fmt::format("study {} failed: {}", s.id, s.message));
}

void Coordinator::handle_unspent(StudyRun& s, int trial_id, const domain::RolloutReport& r, double now_s) {
  InFlight& f = s.in_flight.at(trial_id);
  const std::string worker_id = r.worker_id;
  const bool fault = r.outcome != domain::Outcome::kRefused;
  const std::string outcome = domain::to_string(r.outcome);
  pool_.release(worker_id, s.id, trial_id);
  int faults = 0;
  if (fault) {
    faults = store_.record_unspent_attempt(r, true, wall_now());
  } else {
    // The worker cannot run this study now: keep the study's work off it for a while, twice as long after
    // each identical refusal (at most a minute), or until it says it accepts again, so a refusal never
    // turns into a loop of refusals. Only a new reason is recorded: a study that waits for hours for a
    // worker of its version does not fill the store with the same refusal.
    Refusal& last = s.refused_by[worker_id];
    const bool same = last.why == r.error;
    last.backoff_s = same ? std::min(2.0 * last.backoff_s, 60.0) : options_.refusal_backoff_s;
    last.until_s = now_s + last.backoff_s;
    if (!same) {
      last.why = r.error;
      store_.record_unspent_attempt(r, false, wall_now());
    }
  }
  // A simulated rollout is deterministic for its spec, point and seed: one that diverged diverges again, so
  // it is spent at once. A robot's faults (a watchdog, a glitch) may well not repeat.
  const bool deterministic = r.outcome == domain::Outcome::kDiverged && r.worker_kind == domain::WorkerKind::kSimulation;
  if (fault && (deterministic || faults >= options_.max_fault_retries)) {
    // Spent after all, as a failure the model never sees (excluded): the point was tried often enough.
    const InFlight spent = f;
    const Eigen::VectorXd& x = spent.x;
    if (!store_.complete_trial(r, wall_now())) return;
    const domain::Candidate retired = s.candidate(store_.store_id(), trial_id);
    s.in_flight.erase(trial_id);
    account(s, trial_id, spent, r);
    out_.retire_candidate(retired);
    if (!s.records_retired) out_.publish_trial(s.trial_record(trial_id, x, r));
    warn_(fmt::format("study {} trial {}: {} {} times (last on {}: {}); spent as a failure the model does not learn "
                      "from",
                      s.id, trial_id, outcome, faults, worker_id, r.error));
    fail_on_failure_streak(s, r);
    finish_if_complete(s);
    s.dirty = true;
    if (!s.is_open()) publish_state(s, now_s);
    return;
  }
  info_(fmt::format("study {} trial {}: {} by {} ({}); re-issuing{}", s.id, trial_id, outcome, worker_id,
                    r.error, fault ? fmt::format(" (fault {} of at most {})", faults, options_.max_fault_retries) : ""));
  f.worker_id.clear();
  ++s.reissued;
  s.dirty = true;
}

study::SpecDefaults Coordinator::spec_defaults() const {
  return options_.spec_defaults.model_path.empty() ? study::SpecDefaults::shipped() : options_.spec_defaults;
}

bool Coordinator::has_hardware_worker() const {
  return pool_.has_hardware();
}

bool Coordinator::start_validation_if_due(StudyRun& s) {
  if (s.state != StudyStatus::kRunning || !s.config.validation.enabled || s.validation_started) return false;
  // The answer is final only once every exploration report is in and told to the model.
  if (s.completed < s.config.budget || !s.in_flight.empty() || !s.proposed.empty() || !s.untold.empty() ||
      s.model_busy) {
    return false;
  }
  // The answer: the lowest GP posterior mean over the observations (what StudyState recommends); the
  // best observed point when the model holds none (every rollout failed but one, say).
  Eigen::VectorXd centre;
  if (s.model.has_recommendation && s.model.recommended_x.size() == s.config.space.size()) {
    centre = s.model.recommended_x;
  } else if (s.best_x.size() == s.config.space.size()) {
    centre = s.best_x;
  } else {
    s.state = StudyStatus::kFailed;
    s.message = "validation: no successful exploration rollout to validate around";
    store_.set_state(s.id, to_string(s.state), s.message);
    warn_(fmt::format("study {} failed: {}", s.id, s.message));
    s.dirty = true;
    return false;
  }
  const auto& v = s.config.validation;
  std::vector<study::StoredTrial> stored;
  for (auto& x : validation_sets(s.config.space, centre, v.hardware_sets, v.spread, s.config.optimizer.seed)) {
    study::StoredTrial t;
    t.trial_id = s.next_trial_id++;
    t.x = std::move(x);
    t.issued_at_s = wall_now();
    t.phase = "validation";
    stored.push_back(std::move(t));
  }
  store_.add_trials(s.id, stored);  // all sets at once: a restart issues exactly these
  for (const auto& t : stored) s.in_flight[t.trial_id] = InFlight{t.x, 0, "", 0.0, {}, true};
  s.validation_started = true;
  s.dirty = true;
  info_(fmt::format("study {} '{}': exploration done, {} validation sets (spread +-{:.0f}%) for hardware workers",
                    s.id, s.name, v.hardware_sets, 100.0 * v.spread));
  return true;
}

bool Coordinator::hardware_proposals_due(const StudyRun& s) {
  return s.hardware_to_propose() > 0 && static_cast<int>(s.told_trials.size()) >= s.config.hardware.start_after;
}

void Coordinator::note_hardware_wait(StudyRun& s, double now_s) {
  bool waits = false;
  if (s.state == StudyStatus::kRunning && !has_hardware_worker()) {
    for (const auto& [trial_id, f] : s.in_flight) waits |= f.worker_id.empty() && (f.hardware_only() || s.explores_on_hardware());
    waits |= s.explores_on_hardware() && s.completed < s.config.budget;
    waits |= hardware_proposals_due(s);
  }
  // Work that waits with workers of its kind on the domain, none of which may take it: say who and why.
  std::string blocked;
  if (s.state == StudyStatus::kRunning && !waits) {
    bool sim_work = false, hw_work = false;
    for (const auto& [trial_id, f] : s.in_flight) {
      if (!f.worker_id.empty()) continue;
      (f.hardware_only() || s.explores_on_hardware() ? hw_work : sim_work) = true;
    }
    hw_work |= hardware_proposals_due(s);
    // Exploration still to run whose points wait (proposed, or not yet asked for) with no trial in flight.
    if (s.exploring_in_flight() == 0 && s.completed < s.config.budget) {
      (s.explores_on_hardware() ? hw_work : sim_work) = true;
    }
    std::vector<std::string> reasons;
    bool any_usable = false;
    for (const auto& [id, w] : pool_.all()) {
      if (!((w.hardware && hw_work) || (!w.hardware && sim_work))) continue;
      if (w.accepting && s.may_serve(w, now_s)) {
        any_usable = true;
        break;
      }
      if (!s.is_study_robot(w)) {
        reasons.push_back(fmt::format("robot {} is not the study's robot '{}'", id, s.config.robot));
      } else if (!w.accepting) {
        reasons.push_back(fmt::format("{} {} {}", w.hardware ? "robot" : "worker", id,
                                      w.status.empty() ? std::string("not accepting") : w.status));
      } else if (const auto r = s.refused_by.find(id); r != s.refused_by.end()) {
        // Workers' refusals begin "refused: "; said once.
        const std::string& why = r->second.why;
        reasons.push_back(fmt::format("worker {} refused it: {}", id, why.rfind("refused: ", 0) == 0 ? why.substr(9) : why));
      }
    }
    if (!any_usable && !reasons.empty()) {
      for (const auto& reason : reasons) blocked += (blocked.empty() ? "waiting: " : "; ") + reason;
    }
    // No worker of the kind at all (none started, or started on another domain): said in so many words,
    // not left as a study that is "running" with nothing happening.
    if (sim_work && !pool_.has_simulation()) {
      blocked = fmt::format("waiting for simulation workers: none on {}", options_.where) +
                (blocked.empty() ? "" : "; " + blocked.substr(std::string("waiting: ").size()));
    }
  }
  if (waits == s.waiting_for_hardware && blocked == s.waiting_message) return;
  s.waiting_for_hardware = waits;
  s.waiting_message = blocked;
  if (s.state != StudyStatus::kRunning) return;  // its message is the final one now
  // A transient condition: in the published state only, never in the store (a restart re-derives it).
  std::string work = "the exploration";
  if (s.validation_started) {
    work = fmt::format("validation ({}/{} sets run)", s.validated, s.config.validation.hardware_sets);
  } else if (s.models_hardware()) {
    work = fmt::format("{} ({}/{} hardware rollouts run)", study::to_string(s.config.hardware.strategy), s.hardware_done,
                       s.config.hardware.budget);
  }
  s.message = waits ? fmt::format("waiting_for_hardware: {} needs a hardware worker; none on the domain", work) : blocked;
  if (!s.message.empty()) info_(fmt::format("study {}: {}", s.id, s.message));
  s.dirty = true;
}


void Coordinator::release_optimizer_if_done(StudyRun& s) {
  // A retired study's model is no longer needed (s.model keeps the recommendation), unless a stopped
  // study's candidate still reports or reports wait to be told.
  if (s.records_retired && s.in_flight.empty() && s.untold.empty()) {
    s.optimizer.reset();
    s.hardware_optimizer.reset();
  }
}

int Coordinator::apply_model_results() { return models_.apply_results(); }

void Coordinator::apply_model_result(ModelJobResult result) {
  // On the event thread: only copies and the store write, never model work.
  StudyRun* study = find_study(result.study_id);
  if (study == nullptr) return;
  study->model_busy = false;
  study->asking = 0;
  if (result.hardware) {
    apply_hardware_result(*study, std::move(result));
    release_optimizer_if_done(*study);
    return;
  }
  if (result.proposal_state) study->proposal_state = std::move(*result.proposal_state);
  if (result.fitted) {
    nlohmann::json state = result.fitted->second;
    if (!study->proposal_state.is_null()) state["proposal_state"] = study->proposal_state;
    store_.save_model_state(result.study_id, state);
    study->model = std::move(result.fitted->first);
    study->dirty = true;
  }
  if (!result.error.empty()) {
    warn_(fmt::format("study {}: model job (tell, then ask({})) failed: {}", result.study_id, result.ask, result.error));
  }
  if (result.epoch == study->proposal_epoch) {  // else: numbered for trial ids enqueued gaits took since
    study->proposed.insert(study->proposed.end(), result.points.begin(), result.points.end());
  }
  release_optimizer_if_done(*study);  // a finished study reopened with untold reports kept it for this job
}

void Coordinator::apply_hardware_result(StudyRun& s, ModelJobResult result) {
  if (result.hardware_fitted) {
    store_.save_hardware_model_state(s.id, result.hardware_fitted->second);
    s.hardware_model = std::move(result.hardware_fitted->first);
    s.dirty = true;
  }
  if (!result.error.empty()) {
    warn_(fmt::format("study {}: hardware model job ({}) failed: {}", s.id, result.ask > 0 ? "tell, then ask" : "tell",
                      result.error));
  }
  if (!result.hardware_point || !s.is_open()) return;
  // Stored at once, without a worker (as a validation set): the dispatcher gives it to a robot of the study,
  // and a restart issues this very point.
  const bo::HardwareProposal& p = *result.hardware_point;
  study::StoredTrial t;
  t.trial_id = s.next_trial_id++;
  t.x = p.x;
  t.issued_at_s = wall_now();
  t.phase = "hardware";
  // The safety check goes into the store with the point, so that the record (export, report) says what each
  // robot rollout was expected to risk when it was sent, also after a restart.
  study::HardwareProposalRecord record;
  record.fall_probability = p.fall_probability;
  record.within_fall_limit = p.within_fall_limit;
  record.cost_bound = p.cost_bound;
  if (std::isfinite(p.cost_limit)) record.cost_limit = p.cost_limit;
  record.within_cost_bound = p.within_cost_bound;
  record.basis = bo::to_string(p.basis);
  t.proposal = record;
  store_.add_trials(s.id, {t});
  InFlight f{t.x, 0, "", 0.0, {}};
  f.hardware = true;
  s.in_flight[t.trial_id] = std::move(f);
  s.dirty = true;
  const std::string bound =
      std::isfinite(p.cost_limit)
          ? fmt::format("cost bound {:.4g} {} limit {:.4g}", p.cost_bound, p.within_cost_bound ? "within" : "above",
                        p.cost_limit)
          : fmt::format("cost bound {:.4g}, no robot cost to bound it by yet", p.cost_bound);
  std::string what =
      fmt::format("study {} trial {}: hardware proposal {} of {} ({}; predicted fall probability {:.3f}, {}, expected "
                  "improvement {:.3g})",
                  s.id, t.trial_id, s.hardware_done + s.hardware_in_flight(), s.config.hardware.budget, record.basis,
                  p.fall_probability, bound, p.expected_improvement);
  bool warn = false;
  switch (p.basis) {
    case bo::ProposalBasis::kSimulationOptimum:
      what += ": the first robot rollout, the transferred simulated optimum";
      break;
    case bo::ProposalBasis::kEnqueuedGait:
      what += ": the first robot rollout, the best enqueued gait";
      break;
    case bo::ProposalBasis::kSafe:
      break;
    case bo::ProposalBasis::kLowestBound:
      what += fmt::format("; no candidate under the fall limit was within {:.0f}% of the best robot cost: this is the "
                          "one with the lowest bound",
                          100.0 * s.config.hardware.safe_margin);
      warn = true;
      break;
    case bo::ProposalBasis::kLeastLikelyToFall:
      what += fmt::format("; every candidate was above the fall limit {:.2f}: this is the least likely to fall",
                          s.config.hardware.max_fall_probability);
      warn = true;
      break;
  }
  if (!p.within_fall_limit && p.basis != bo::ProposalBasis::kLeastLikelyToFall) {
    // The start point is run as the rule says even when a classifier puts it above the limit (it walked
    // in simulation); said, so that an operator can watch that rollout.
    what += fmt::format("; above the fall limit {:.2f}", s.config.hardware.max_fall_probability);
    warn = true;
  }
  (warn ? warn_ : info_)(what);
}

// ---- reports -------------------------------------------------------------------------------------

void Coordinator::handle_report(const domain::RolloutReport& r, double now_s,
                                const std::optional<std::string>& sender_identity) {
  const std::string what = fmt::format("report for study {} trial {} from {}", r.id.study_id, r.id.trial_id,
                                       r.worker_id);
  if (r.id.store_id != 0 && r.id.store_id != store_.store_id()) {
    // Another store's candidate (a second optimizer on this domain, or one that ran before on the same
    // workers): its study and trial ids mean nothing here. Not a malformed sample; said once per store.
    if (foreign_stores_.insert(r.id.store_id).second) {
      warn_(fmt::format("ignoring reports for another store (store_id {:016x}; this one is {:016x}): another "
                        "optimizer on this domain?",
                        r.id.store_id, store_.store_id()));
    }
    ++foreign_reports_;
    return;
  }
  if (auto why = domain::check_report(r)) return reject(what, *why);
  StudyRun* s = find_study(r.id.study_id);
  if (s == nullptr) return reject(what, "unknown study");
  if (r.ok() && s->config.optimizer.cost_transform == bo::CostTransform::kLog && !(r.summary.cost > 0.0)) {
    // The model fits log(cost): a non-positive cost would poison it. No rollout cost is <= 0 (J_distance > 0).
    return reject(what, fmt::format("cost {} must be > 0 in a study with cost_transform: log", r.summary.cost));
  }
  const int trial_id = r.id.trial_id;
  const auto it = s->in_flight.find(trial_id);
  if (it == s->in_flight.end()) {
    if (trial_id < s->next_trial_id) {
      info_(fmt::format("ignored a duplicate {} (already counted)", what));
      return;
    }
    return reject(what, "no such candidate was ever issued");
  }
  if (r.id.attempt > it->second.attempt) {
    return reject(what, fmt::format("attempt {} was never issued (last: {})", r.id.attempt, it->second.attempt));
  }
  if (const auto to = it->second.issued_to.find(r.id.attempt);
      to == it->second.issued_to.end() || to->second != r.worker_id) {
    return reject(what, fmt::format("attempt {} was assigned to {}", r.id.attempt,
                                    to == it->second.issued_to.end() ? std::string("no worker") : to->second));
  }
  // The worker_id names the assigned worker; with DDS-Security it must also be the sender's own.
  if (auto why = identity_refusal(r.worker_id, sender_identity)) return reject(what, *why);
  // The assigned worker answered an attempt of its own: it is no longer on probation (counted or not).
  if (pool_.end_probation(r.worker_id)) {
    const PoolWorker* w = pool_.find(r.worker_id);
    info_(fmt::format("worker {} reported again: off probation, all its {} slots usable", r.worker_id,
                      w == nullptr ? 0 : w->slots));
  }
  if (domain::reissued_not_spent(r.outcome)) {
    if (r.id.attempt != it->second.attempt || it->second.worker_id != r.worker_id) {
      info_(fmt::format("ignored a stale {} ({}): attempt {} is no longer the trial's current one", what,
                        domain::to_string(r.outcome), r.id.attempt));
      return;
    }
    return handle_unspent(*s, trial_id, r, now_s);
  }
  const InFlight spent = it->second;
  const Eigen::VectorXd& x = spent.x;
  if (!store_.complete_trial(r, wall_now())) {
    info_(fmt::format("ignored a duplicate {} (already in the store)", what));
    return;
  }
  pool_.release(it->second.worker_id, s->id, trial_id);
  const domain::Candidate retired = s->candidate(store_.store_id(), trial_id);
  s->in_flight.erase(it);
  account(*s, trial_id, spent, r);
  out_.retire_candidate(retired);
  if (!s->records_retired) out_.publish_trial(s->trial_record(trial_id, x, r));  // else: the store has it
  if (!r.ok()) warn_(fmt::format("study {} trial {}: rollout failed on {}: {}", s->id, trial_id, r.worker_id, r.error));
  fail_on_failure_streak(*s, r);
  finish_if_complete(*s);
  if (!s->is_open()) publish_state(*s, now_s);
}

void Coordinator::count_report(StudyRun& s, int trial_id, const Eigen::VectorXd& x, const domain::RolloutReport& r) {
  s.untold.emplace_back(trial_id, StudyRun::observation(x, r));
  s.account_report(trial_id, x, r);
}

void Coordinator::account(StudyRun& s, int trial_id, const InFlight& spent, const domain::RolloutReport& r) {
  if (spent.validation) {
    s.account_validation(trial_id, r);
  } else if (spent.hardware) {
    s.account_hardware(trial_id, spent.x, r);  // for the hardware model's next job
  } else {
    count_report(s, trial_id, spent.x, r);
  }
}

void Coordinator::finish_if_complete(StudyRun& s) {
  if (s.state != StudyStatus::kRunning || !s.complete()) return;
  const auto& v = s.config.validation;
  s.state = StudyStatus::kDone;
  s.message = fmt::format("{} rollouts, best cost {:.4g} (trial {})", s.completed, s.best_cost, s.best_trial);
  if (v.enabled) s.message += fmt::format("; {} validation sets run on hardware", s.validated);
  if (s.models_hardware()) {
    s.message += fmt::format("; {} hardware rollouts ({})", s.hardware_done, study::to_string(s.config.hardware.strategy));
    if (s.hardware_model.has_recommendation) {
      s.message += fmt::format(", answer: hardware trial {} (predicted cost {:.4g})", s.hardware_model.recommended_trial,
                               s.hardware_model.recommended_predicted_cost);
    }
  }
  store_.set_state(s.id, to_string(s.state), s.message);
  info_(fmt::format("study {} '{}' done: {}", s.id, s.name, s.message));
  s.dirty = true;
}

// ---- time ----------------------------------------------------------------------------------------

void Coordinator::publish_state(StudyRun& s, double now_s) {
  out_.publish_state(s.state_sample(pool_.size(), wall_now(), now_s));
  s.dirty = false;
  last_state_publish_[s.id] = now_s;
}

void Coordinator::retire_finished(StudyRun& s, double now_s) {
  if (s.is_open() || s.records_retired) return;
  if (s.records_leave_at_s < 0.0) s.records_leave_at_s = now_s + options_.finished_records_grace_s;
  if (now_s < s.records_leave_at_s || s.model_busy || !s.untold.empty()) return;
  std::vector<int> records = s.told_trials;
  records.insert(records.end(), s.validation_trials.begin(), s.validation_trials.end());
  records.insert(records.end(), s.hardware_trials.begin(), s.hardware_trials.end());
  for (const int trial_id : records) {
    domain::TrialRecord key;
    key.study_id = s.id;
    key.trial_id = trial_id;
    out_.retire_trial(key);
  }
  s.records_retired = true;
  // Its spec leaves the topic too, unless another open study runs the same spec.
  const bool shared = std::any_of(studies_.begin(), studies_.end(), [&](const auto& kv) {
    return kv.second.id != s.id && kv.second.is_open() && kv.second.spec && kv.second.spec->key() == s.spec->key();
  });
  if (!shared && s.spec) out_.retire_spec(s.spec_publication());
  release_optimizer_if_done(s);
}

void Coordinator::tick(double now_s) {
  now_s_ = now_s;
  dispatcher_.start_tick(options_.max_issues_per_tick);
  apply_model_results();
  for (const auto& id : pool_.silent(now_s, options_.worker_timeout_s)) drop_worker(id, fmt::format("silent for over {:.1f} s", options_.worker_timeout_s), now_s);
  for (auto& [sid, s] : studies_) {
    for (auto& [trial_id, f] : s.in_flight) {
      if (f.worker_id.empty() || now_s <= f.deadline_s) continue;
      pool_.release(f.worker_id, s.id, trial_id);
      // It took a candidate and did not answer in time: until it answers, one candidate at a time, so a
      // worker that claims many slots and never reports cannot hold a study's work lease after lease.
      if (pool_.put_on_probation(f.worker_id)) {
        warn_(fmt::format("worker {} on probation: the lease of study {} trial {} expired; at most 1 candidate at a "
                          "time until it reports",
                          f.worker_id, s.id, trial_id));
      }
      unassign(s, trial_id, "lease expired");
    }
  }
  const std::vector<StudyRun*> order = round_robin_order();
  const FreeSlots free = dispatcher_.issue_waiting_work(order, now_s);
  models_.start_jobs(studies_, order, free.simulation, free.hardware, [&](const StudyRun& s) {
    int usable = 0;
    for (const PoolWorker* w : pool_.free_slots(true)) usable += s.may_serve(*w, now_s) ? 1 : 0;
    return usable;
  });
  // Without model threads the jobs just started have finished already: issue their points now.
  if (apply_model_results() > 0) dispatcher_.issue_waiting_work(order, now_s);
  bool validation_started = false;
  for (StudyRun* s : order) validation_started |= start_validation_if_due(*s);
  if (validation_started) dispatcher_.issue_waiting_work(order, now_s);
  for (StudyRun* s : order) {
    finish_if_complete(*s);
    note_hardware_wait(*s, now_s);
  }
  for (auto& [sid, s] : studies_) {
    retire_finished(s, now_s);
    const auto last = last_state_publish_.find(sid);
    if (s.dirty && (last == last_state_publish_.end() || now_s - last->second >= kStatePublishPeriod_s)) {
      publish_state(s, now_s);
    }
  }
}

}  // namespace cpgmatch::service
