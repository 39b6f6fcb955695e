#include <chrono>

#include "cpgmatch/seeds.hpp"
#include "cpgmatch/service/coordinator.hpp"

#include <algorithm>
#include <set>
#include <vector>
#include <cmath>
#include <optional>

#include <fmt/format.h>

#include "cpgmatch/domain/report_json.hpp"
#include "cpgmatch/domain/worker_identity.hpp"
#include "cpgmatch/errors.hpp"
#include "cpgmatch/bo/model_state_json.hpp"
#include "cpgmatch/service/validation_sets.hpp"

namespace cpgmatch::service {

namespace {

// A study state sample at most this often while nothing terminal happens (a busy study would
// otherwise publish one per report).
constexpr double kStatePublishPeriod_s = 0.1;
constexpr std::size_t kMaxReplies = 1024;

// How many observations the study's saved model state was fitted on; nothing without a usable state
// (restored_optimizer() then says why and replays every report).
std::optional<int> saved_state_observations(const study::StoredStudy* stored) {
  if (stored == nullptr || !stored->model_state.is_object()) return std::nullopt;
  try {
    const int n = bo::model_state_from_json(stored->model_state).observations;
    return n >= 0 ? std::optional<int>(n) : std::nullopt;
  } catch (const std::exception&) {
    return std::nullopt;
  }
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
                     "defaults this release ships (objective version {}, the science of the release that wrote it)",
                     study::kObjectiveVersion);
}

}  // namespace

void DeferredOutbox::release() {
  holding_ = false;
  auto held = std::move(held_);
  held_.clear();
  for (auto& send : held) send(target_);
}

void DeferredOutbox::discard() {
  holding_ = false;
  held_.clear();
}

Coordinator::Coordinator(study::StudyStore& store, Outbox& outbox, CoordinatorOptions options, LogFn log_info,
                         LogFn log_warning)
    : store_(store),
      out_(outbox),
      options_(std::move(options)),
      info_(std::move(log_info)),
      warn_(std::move(log_warning)),
      models_(options_.model_threads, options_.on_model_result) {}

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

Coordinator::Study* Coordinator::find_study(int study_id) {
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

void Coordinator::resume_from_store(double now_s) {
  for (const study::StoredStudy& stored : store_.load_all()) {
    Study s;
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
            study::StudySpec::resolve(stored.config_yaml, stored.source_name, spec_defaults()));
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
    }
  }
  if (!studies_.empty()) info_(fmt::format("resumed {} studies from {}", studies_.size(), store_.path()));
}

void Coordinator::open_study(Study&& fresh, const study::StoredStudy* stored, double now_s) {
  const int id = fresh.id;
  auto [it, inserted] = studies_.emplace(id, std::move(fresh));
  Study& s = it->second;
  std::vector<const study::StoredTrial*> done, validated;
  if (stored != nullptr) {
    for (const auto& t : stored->trials) {
      s.next_trial_id = std::max(s.next_trial_id, t.trial_id + 1);
      const bool validation = t.phase == "validation";
      if (validation) s.validation_started = true;
      if (t.status == study::TrialStatus::kDone) {
        (validation ? validated : done).push_back(&t);
      } else {
        // Re-issued once a slot is free; the worker it last went to may still report that attempt. A
        // validation set stored but never issued has no worker yet: it is issued, not re-issued.
        InFlight f{t.x, t.attempt, "", 0.0, {}, validation};
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
  if (s.config.lockstep > 0) {
    // Lockstep: the optimizer holds trials 0..T-1 in trial order, T = what its saved state was fitted on;
    // the other reports wait in `untold` until an ask needs them, exactly as they would have.
    std::sort(done.begin(), done.end(),
              [](const study::StoredTrial* a, const study::StoredTrial* b) { return a->trial_id < b->trial_id; });
    const auto told = static_cast<std::size_t>(saved_state_observations(stored).value_or(0));
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
    const std::optional<int> saved = saved_state_observations(stored);
    const std::size_t told =
        saved && static_cast<std::size_t>(*saved) <= done.size() ? static_cast<std::size_t>(*saved) : done.size();
    for (std::size_t i = 0; i < done.size(); ++i) {
      if (i < told) {
        observations.push_back(stored_observation(*done[i]));
        s.told_trials.push_back(done[i]->trial_id);
      } else {
        s.untold.emplace_back(done[i]->trial_id, stored_observation(*done[i]));
      }
    }
  }
  s.optimizer = std::make_shared<bo::BayesianOptimizer>(restored_optimizer(s, stored, observations));
  s.model = snapshot_of(*s.optimizer, s.told_trials);
  for (const auto* t : done) {
    const int trial_id = t->trial_id;
    std::string why;
    const domain::RolloutReport report = replayed_report(*t, &why);
    if (!why.empty()) {
      warn_(fmt::format("study {} trial {}: stored report unreadable ({}); counted as failed", id, trial_id, why));
    }
    account_report(s, trial_id, t->x, report);  // the optimizer already holds it: counters and best only
    // A finished study's records are served from the store (analyze, plot), not kept on the topic.
    if (is_open(s)) out_.publish_trial(make_trial_record(s, trial_id, t->x, report));
  }
  std::sort(validated.begin(), validated.end(),
            [](const study::StoredTrial* a, const study::StoredTrial* b) { return a->trial_id < b->trial_id; });
  for (const auto* t : validated) {
    const domain::RolloutReport report = replayed_report(*t, nullptr);
    account_validation(s, t->trial_id, report);
    if (is_open(s)) out_.publish_trial(make_trial_record(s, t->trial_id, t->x, report));
  }
  s.records_retired = !is_open(s);
  if (is_open(s)) out_.publish_spec(spec_sample(s));  // before any of its candidates
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

bo::BayesianOptimizer Coordinator::restored_optimizer(const Study& s, const study::StoredStudy* stored,
                                                      const std::vector<bo::Observation>& observations) const {
  if (observations.empty()) return bo::BayesianOptimizer(s.config.space, s.config.optimizer);
  if (stored != nullptr && stored->model_state.is_object()) {
    try {
      return bo::BayesianOptimizer::restore(s.config.space, s.config.optimizer, observations,
                                            bo::model_state_from_json(stored->model_state));
    } catch (const std::exception& e) {
      warn_(fmt::format("study {}: saved model state unusable ({}); replaying {} observations instead", s.id, e.what(),
                        observations.size()));
    }
  } else {
    info_(fmt::format("study {}: no saved model state (older store); replaying {} observations", s.id,
                      observations.size()));
  }
  return bo::BayesianOptimizer::rebuild(s.config.space, s.config.optimizer, observations);
}

void Coordinator::submit(const domain::StudyCommand& command, double now_s, domain::CommandReply& reply) {
  const std::string source = !command.source_name.empty() ? command.source_name : "submitted study";
  std::shared_ptr<const study::StudySpec> spec;
  if (command.study_yaml.size() > study::kMaxStudyFileBytes) {
    // Refused before any parsing: a 12 MB file of 700k keys took the service to 800 MB and stalled its
    // event loop for 2.5 s (a healthy worker was declared silent meanwhile).
    reply.ok = false;
    reply.message = fmt::format("{}: {} bytes, more than a study file may have ({} bytes)", source,
                              command.study_yaml.size(), study::kMaxStudyFileBytes);
    warn_(fmt::format("submit from {} refused: {}", command.client_id, reply.message));
    return;
  }
  try {
    spec = std::make_shared<const study::StudySpec>(
        study::StudySpec::resolve(command.study_yaml, source, spec_defaults()));
  } catch (const std::exception& e) {
    reply.ok = false;
    reply.message = e.what();
    warn_(fmt::format("submit from {} refused: {}", command.client_id, e.what()));
    return;
  }
  Study s;
  s.spec = spec;
  s.config = spec->config();
  s.name = s.config.name;
  s.created_at_s = wall_now();
  s.id = store_.create_study(s.name, command.study_yaml, source, s.created_at_s,
                             study::StoredSpec{spec->canonical_json(), spec->sha256(), study::kOriginSubmitted});
  const int id = s.id;
  info_(fmt::format("study {} '{}' submitted: budget {}, {} parameters", id, s.name, s.config.budget,
                    s.config.space.size()));
  open_study(std::move(s), nullptr, now_s);
  reply.ok = true;
  reply.study_id = id;
  reply.message = fmt::format("study {} '{}' accepted (spec {})", id, studies_.at(id).name, spec->sha256().substr(0, 16));
}

void Coordinator::handle_command(const domain::StudyCommand& command, double now_s) {
  const auto key = std::make_pair(command.client_id, command.correlation_id);
  if (const auto done = replies_.find(key); done != replies_.end()) {
    out_.reply(done->second);  // a re-sent command: same answer, not a second execution
    return;
  }
  domain::CommandReply reply;
  reply.correlation_id = command.correlation_id;
  reply.client_id = command.client_id;
  reply.study_id = command.study_id;
  reply.ok = false;
  try {
    if (command.kind == domain::CommandKind::kSubmit) {
      submit(command, now_s, reply);
    } else {
      Study* s = find_study(command.study_id);
      if (s == nullptr) {
        reply.message = fmt::format("no study {}", command.study_id);
      } else {
        const StudyStatus wanted = command.kind == domain::CommandKind::kPause    ? StudyStatus::kPaused
                                   : command.kind == domain::CommandKind::kResume ? StudyStatus::kRunning
                                                                           : StudyStatus::kStopped;
        std::optional<StudyStatus> target;
        if (wanted == StudyStatus::kPaused && s->state == StudyStatus::kRunning) target = wanted;
        if (wanted == StudyStatus::kRunning && s->state == StudyStatus::kPaused) target = wanted;
        if (wanted == StudyStatus::kStopped && is_open(*s)) target = wanted;
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
      }
    }
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
  replies_[key] = reply;
  reply_order_.push_back(key);
  if (reply_order_.size() > kMaxReplies) {
    replies_.erase(reply_order_.front());
    reply_order_.pop_front();
  }
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

void Coordinator::handle_worker_gone(std::uint64_t worker_key, double now_s,
                                     const std::optional<std::string>& disposed_by) {
  const PoolWorker* w = pool_.by_key(worker_key);
  if (w == nullptr) return;
  const std::string id = w->id;
  if (disposed_by) {
    if (auto why = identity_refusal(id, disposed_by)) return reject("dispose of worker " + id, *why);
  }
  drop_worker(id, "left the domain", now_s);
}

void Coordinator::unassign(Study& study, int trial_id, const std::string& why) {
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
    if (Study* s = find_study(study_id)) unassign(*s, trial_id, "worker " + why);
  }
  for (auto& [sid, s] : studies_) s.dirty = true;
}

// ---- candidates ----------------------------------------------------------------------------------

domain::Candidate Coordinator::make_candidate(const Study& study, int trial_id, const InFlight& f) const {
  domain::Candidate c;
  c.id = domain::AttemptId{store_.store_id(), study.id, trial_id, f.attempt};
  c.worker_id = f.worker_id;
  c.lease_s = study.config.effective_lease_s();
  c.spec_key = study.spec->key();
  c.rollout.entrain_s = study.config.entrain_s;
  c.rollout.eval_s = study.config.eval_s;
  c.rollout.terrain = study.config.terrain;
  // Each trial gets its own rollout seed (sensor noise, rough ground): the optimizer then sees the
  // rollout-to-rollout spread it must be robust to, instead of one frozen noise realisation that a lucky
  // point can exploit. Still a pure function of (study seed, trial id): same seed, same study.
  c.rollout.seed = derived_seed(study.config.optimizer.seed, static_cast<std::uint64_t>(trial_id));
  c.parameters = to_map(study.spec->base_parameters());
  for (const auto& [name, value] : study.config.space.to_named(f.x)) c.parameters[name] = value;
  return c;
}

void Coordinator::issue(Study& study, int trial_id, PoolWorker& worker, double now_s, bool reissue) {
  InFlight& f = study.in_flight.at(trial_id);
  if (reissue) {
    ++f.attempt;
    store_.reissue(study.id, trial_id, f.attempt, worker.id, wall_now());
  } else if (f.validation) {
    // Stored without a worker at the phase's start: record who has it, so a restart after this point
    // still accepts that worker's report.
    store_.reissue(study.id, trial_id, f.attempt, worker.id, wall_now());
  }
  f.worker_id = worker.id;
  f.issued_to[f.attempt] = worker.id;
  f.deadline_s = now_s + study.config.effective_lease_s();
  pool_.assign(worker.id, study.id, trial_id);
  out_.send_candidate(make_candidate(study, trial_id, f));
  study.dirty = true;
}


std::vector<Coordinator::Study*> Coordinator::round_robin_order() {
  std::vector<Study*> order;
  for (auto& [id, s] : studies_) order.push_back(&s);
  if (order.empty()) return order;
  std::rotate(order.begin(), order.begin() + (round_robin_++ % static_cast<int>(order.size())), order.end());
  return order;
}

Coordinator::FreeSlots Coordinator::issue_waiting_work(const std::vector<Study*>& order, double now_s) {
  struct Slots {
    std::vector<PoolWorker*> slots;
    std::size_t next = 0;
    int free() const { return static_cast<int>(slots.size() - next); }
    // Moves the free slots this study may use to the front (in their order) and says how many there are:
    // a worker within a refusal's backoff for this study serves the other studies meanwhile.
    int usable_for(const Study& study, double now) {
      const auto first = slots.begin() + static_cast<std::ptrdiff_t>(next);
      const auto end = std::stable_partition(first, slots.end(), [&](const PoolWorker* w) { return may_serve(study, *w, now); });
      return static_cast<int>(end - first);
    }
  };
  Slots sim{pool_.free_slots(false)}, hw{pool_.free_slots(true)};
  // Every candidate written this tick counts against max_issues_per_tick (the DDS writes of a full fill
  // would stall the event loop, see CoordinatorOptions), whichever kind of slot it goes to: a tick that
  // reaches the cap leaves the other slots free for the next ticks, and they still count as free below.
  for (Study* s : order) {
    if (s->state != StudyStatus::kRunning) continue;
    Slots& explore = explores_on_hardware(*s) ? hw : sim;
    // Re-issues (and stored validation sets) first: they are the oldest work.
    for (auto& [trial_id, f] : s->in_flight) {
      if (!f.worker_id.empty()) continue;
      Slots& kind = f.validation ? hw : explore;
      if (issues_left_this_tick_ <= 0 || kind.usable_for(*s, now_s) == 0) continue;
      issue(*s, trial_id, *kind.slots[kind.next++], now_s, !f.issued_to.empty());
      --issues_left_this_tick_;
    }
    const std::size_t before = explore.next;
    const int usable = explore.usable_for(*s, now_s);
    issue_proposed(*s, explore.slots, explore.next, std::max(0, std::min(issues_left_this_tick_, usable)), now_s);
    issues_left_this_tick_ -= static_cast<int>(explore.next - before);
  }
  return {sim.free(), hw.free()};
}

bool Coordinator::may_serve(const Study& study, const PoolWorker& worker, double now_s) {
  if (!is_study_robot(study, worker)) return false;
  const auto r = study.refused_by.find(worker.id);
  return r == study.refused_by.end() || now_s >= r->second.until_s;
}

void Coordinator::fail_on_failure_streak(Study& s, const domain::RolloutReport& r) {
  if (s.state != StudyStatus::kRunning || s.consecutive_failures < options_.max_consecutive_failures) return;
  s.state = StudyStatus::kFailed;
  s.message = fmt::format("{} rollouts in a row could not run; last error: {}", s.consecutive_failures,
                          r.error);
  store_.set_state(s.id, to_string(s.state), s.message);
  warn_(fmt::format("study {} failed: {}", s.id, s.message));
}

void Coordinator::handle_unspent(Study& s, int trial_id, const domain::RolloutReport& r, double now_s) {
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
    const Eigen::VectorXd x = f.x;
    const bool validation = f.validation;
    if (!store_.complete_trial(r, wall_now())) return;
    const domain::Candidate retired = make_candidate(s, trial_id, f);
    s.in_flight.erase(trial_id);
    if (validation) account_validation(s, trial_id, r);
    else count_report(s, trial_id, x, r);
    out_.retire_candidate(retired);
    if (!s.records_retired) out_.publish_trial(make_trial_record(s, trial_id, x, r));
    warn_(fmt::format("study {} trial {}: {} {} times (last on {}: {}); spent as a failure the model does not learn "
                      "from",
                      s.id, trial_id, outcome, faults, worker_id, r.error));
    fail_on_failure_streak(s, r);
    finish_if_complete(s);
    s.dirty = true;
    if (!is_open(s)) publish_state(s, now_s);
    return;
  }
  info_(fmt::format("study {} trial {}: {} by {} ({}); re-issuing{}", s.id, trial_id, outcome, worker_id,
                    r.error, fault ? fmt::format(" (fault {} of at most {})", faults, options_.max_fault_retries) : ""));
  f.worker_id.clear();
  ++s.reissued;
  s.dirty = true;
}

bool Coordinator::is_study_robot(const Study& study, const PoolWorker& worker) {
  const std::string& robot = study.config.robot;
  // The same rule as a worker id and its certificate: the robot's name, or the name and a suffix.
  return !worker.hardware || robot.empty() || domain::worker_id_belongs_to(worker.id, robot);
}

domain::SpecPublication Coordinator::spec_sample(const Study& s) {
  return domain::SpecPublication{s.spec->key(), s.spec->objective_version(), s.spec->sha256(), s.spec->canonical_json()};
}

study::SpecDefaults Coordinator::spec_defaults() const {
  return options_.spec_defaults.model_path.empty() ? study::SpecDefaults::shipped() : options_.spec_defaults;
}

int Coordinator::exploring_in_flight(const Study& s) {
  return static_cast<int>(std::count_if(s.in_flight.begin(), s.in_flight.end(),
                                        [](const auto& kv) { return !kv.second.validation; }));
}

bool Coordinator::has_hardware_worker() const {
  return pool_.has_hardware();
}

bool Coordinator::start_validation_if_due(Study& s) {
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

void Coordinator::note_hardware_wait(Study& s, double now_s) {
  bool waits = false;
  if (s.state == StudyStatus::kRunning && !has_hardware_worker()) {
    for (const auto& [trial_id, f] : s.in_flight) waits |= f.worker_id.empty() && (f.validation || explores_on_hardware(s));
    waits |= explores_on_hardware(s) && s.completed < s.config.budget;
  }
  // Work that waits with workers of its kind on the domain, none of which may take it: say who and why.
  std::string blocked;
  if (s.state == StudyStatus::kRunning && !waits) {
    bool sim_work = false, hw_work = false;
    for (const auto& [trial_id, f] : s.in_flight) {
      if (!f.worker_id.empty()) continue;
      (f.validation || explores_on_hardware(s) ? hw_work : sim_work) = true;
    }
    // Exploration still to run whose points wait (proposed, or not yet asked for) with no trial in flight.
    if (exploring_in_flight(s) == 0 && s.completed < s.config.budget) {
      (explores_on_hardware(s) ? hw_work : sim_work) = true;
    }
    std::vector<std::string> reasons;
    bool any_usable = false;
    for (const auto& [id, w] : pool_.all()) {
      if (!((w.hardware && hw_work) || (!w.hardware && sim_work))) continue;
      if (w.accepting && may_serve(s, w, now_s)) {
        any_usable = true;
        break;
      }
      if (!is_study_robot(s, w)) {
        reasons.push_back(fmt::format("robot {} is not the study's robot '{}'", id, s.config.robot));
      } else if (!w.accepting) {
        reasons.push_back(fmt::format("{} {} {}", w.hardware ? "robot" : "worker", id,
                                      w.status.empty() ? std::string("not accepting") : w.status));
      } else if (const auto r = s.refused_by.find(id); r != s.refused_by.end()) {
        reasons.push_back(fmt::format("worker {} refused it: {}", id, r->second.why));
      }
    }
    if (!any_usable && !reasons.empty()) {
      for (const auto& reason : reasons) blocked += (blocked.empty() ? "waiting: " : "; ") + reason;
    }
  }
  if (waits == s.waiting_for_hardware && blocked == s.waiting_message) return;
  s.waiting_for_hardware = waits;
  s.waiting_message = blocked;
  if (s.state != StudyStatus::kRunning) return;  // its message is the final one now
  // A transient condition: in the published state only, never in the store (a restart re-derives it).
  s.message = waits ? fmt::format("waiting_for_hardware: {} needs a hardware worker; none on the domain",
                                  s.validation_started ? fmt::format("validation ({}/{} sets run)", s.validated,
                                                                     s.config.validation.hardware_sets)
                                                       : std::string("the exploration"))
                    : blocked;
  if (!s.message.empty()) info_(fmt::format("study {}: {}", s.id, s.message));
  s.dirty = true;
}

void Coordinator::account_validation(Study& s, int trial_id, const domain::RolloutReport& r) {
  ++s.validated;
  s.validation_trials.push_back(trial_id);
  count_outcome(s, r);
}

bool Coordinator::count_outcome(Study& s, const domain::RolloutReport& r) {
  s.dirty = true;
  if (!r.ok()) {
    ++s.failed;
    ++s.consecutive_failures;
    return false;
  }
  s.consecutive_failures = 0;
  if (r.fell()) ++s.falls;
  return true;
}

void Coordinator::issue_proposed(Study& s, std::vector<PoolWorker*>& slots, std::size_t& next_slot, int max_count,
                                 double now_s) {
  std::vector<study::StoredTrial> stored;
  while (!s.proposed.empty() && next_slot + stored.size() < slots.size() &&
         static_cast<int>(stored.size()) < max_count) {
    study::StoredTrial t;
    t.trial_id = s.next_trial_id++;
    t.x = std::move(s.proposed.front());
    s.proposed.pop_front();
    t.worker_id = slots[next_slot + stored.size()]->id;
    t.issued_at_s = wall_now();
    stored.push_back(std::move(t));
  }
  if (stored.empty()) return;
  store_.add_trials(s.id, stored);  // committed before anything is published
  for (const auto& t : stored) {
    s.in_flight[t.trial_id] = InFlight{t.x, 0, "", 0.0, {}};
    issue(s, t.trial_id, *slots[next_slot++], now_s, false);
  }
}

void Coordinator::start_model_jobs(const std::vector<Study*>& order, FreeSlots free) {
  // Slots that a job already running will fill are not asked for twice; each study asks only for slots
  // of the kind its exploration runs on.
  // Points already proposed and waiting for a slot (the issue cap held them back) will fill free slots too.
  int wanted[2] = {free.simulation, free.hardware};
  for (const auto& [id, s] : studies_) {
    wanted[explores_on_hardware(s)] -= s.asking + (s.state == StudyStatus::kRunning ? static_cast<int>(s.proposed.size()) : 0);
  }
  int new_budget = options_.max_new_candidates_per_tick;  // points asked for this tick, over all studies
  for (Study* s : order) {
    if (s->model_busy || !s->optimizer) continue;
    int n = 0;
    int& wanted_here = wanted[explores_on_hardware(*s)];
    if (s->state == StudyStatus::kRunning) {
      const int remaining = s->config.budget - s->completed - exploring_in_flight(*s) -
                            static_cast<int>(s->proposed.size());
      n = std::max(0, std::min({remaining, wanted_here, new_budget}));
    }
    if (s->config.lockstep > 0) {
      n = std::min(n, lockstep_room(*s));
      // Telling early would change later proposals: reports wait for the ask that needs them, or for the
      // end of the exploration (every trial proposed), when they are all told. A paused study waits too.
      const bool all_proposed = s->next_trial_id + static_cast<int>(s->proposed.size()) >= s->config.budget;
      if (n == 0 && !(all_proposed && lockstep_tellable(*s) > 0)) continue;
    }
    if (n == 0 && s->untold.empty()) continue;
    wanted_here -= n;
    new_budget -= n;
    start_model_job(*s, n);
  }
  // Studies not in the rotation (none today) keep their reports until the next tick.
}

Coordinator::ModelSnapshot Coordinator::snapshot_of(const bo::BayesianOptimizer& optimizer,
                                                    const std::vector<int>& told_trials) {
  ModelSnapshot m;
  if (const auto rec = optimizer.recommended()) {
    m.has_recommendation = true;
    m.recommended_trial = told_trials.at(rec->observation);
    m.recommended_predicted_cost = rec->predicted;
    m.recommended_x = optimizer.observations()[rec->observation].x;
    m.recommended_params = optimizer.space().to_named(m.recommended_x);
  }
  return m;
}

void Coordinator::release_optimizer_if_done(Study& s) {
  // A retired study's model is no longer needed (s.model keeps the recommendation), unless a stopped
  // study's candidate still reports or reports wait to be told.
  if (s.records_retired && s.in_flight.empty() && s.untold.empty()) s.optimizer.reset();
}

ModelPool::Completion Coordinator::model_job_result(int id, int ask, FittedModel fitted,
                                                   std::vector<Eigen::VectorXd> points, std::string error) {
  // On the event thread: only copies and the store write, never model work.
  return [this, id, fitted = std::move(fitted), points = std::move(points), ask, error = std::move(error)] {
    Study* study = find_study(id);
    if (study == nullptr) return;
    study->model_busy = false;
    study->asking = 0;
    if (fitted) {
      store_.save_model_state(id, fitted->second);
      study->model = fitted->first;
      study->dirty = true;
    }
    if (!error.empty()) warn_(fmt::format("study {}: model job (tell, then ask({})) failed: {}", id, ask, error));
    study->proposed.insert(study->proposed.end(), points.begin(), points.end());
    release_optimizer_if_done(*study);  // a finished study reopened with untold reports kept it for this job
  };
}

int Coordinator::lockstep_tellable(const Study& s) {
  std::set<int> reported;
  for (const auto& [trial_id, observation] : s.untold) reported.insert(trial_id);
  int next = static_cast<int>(s.told_trials.size());
  while (reported.count(next) > 0) ++next;
  return next - static_cast<int>(s.told_trials.size());
}

int Coordinator::lockstep_room(const Study& s) {
  // Trial k may be proposed once trials 0..k-N-1 have reported.
  const int next_to_propose = s.next_trial_id + static_cast<int>(s.proposed.size());
  const int reported_prefix = static_cast<int>(s.told_trials.size()) + lockstep_tellable(s);
  return std::max(0, reported_prefix + s.config.lockstep - next_to_propose);
}

void Coordinator::start_lockstep_model_job(Study& s, int ask) {
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
      warn_(fmt::format("study {}: lockstep: trial {} has no point; asking nothing this time", s.id, id));
      return;
    }
  }
  // Tells: what the last ask needs (trials up to k_last - N - 1), and at the end every reported trial.
  const bool final_asks = k0 + ask >= s.config.budget;
  const int tellable = lockstep_tellable(s);
  const int needed = ask > 0 ? std::max(0, k0 + ask - 1 - lag - told0) : 0;
  const int tells_count = final_asks ? tellable : std::min(needed, tellable);
  std::vector<bo::Observation> tells;
  for (int i = 0; i < tells_count; ++i) {
    tells.push_back(reported.at(told0 + i));
    s.told_trials.push_back(told0 + i);
  }
  s.untold.erase(std::remove_if(s.untold.begin(), s.untold.end(),
                                [&](const auto& kv) { return kv.first < told0 + tells_count; }),
                 s.untold.end());
  use_idle_model_threads(s);
  s.model_busy = true;
  s.asking = ask;
  const int id = s.id;
  auto work = [this, id, optimizer = s.optimizer, told_trials = s.told_trials, tells = std::move(tells),
               xs = std::move(xs), ask, lag, told0, k0]() mutable -> ModelPool::Completion {
    if (options_.model_job_hook) options_.model_job_hook(id);
    std::vector<Eigen::VectorXd> points;
    std::string error;
    FittedModel fitted;
    try {
      int told = told0;
      auto tell_next = [&] { optimizer->tell_batch({tells[static_cast<std::size_t>(told++ - told0)]}); };
      for (int k = k0; k < k0 + ask; ++k) {
        while (told < k - lag) tell_next();  // exactly trials 0..k-N-1, one fit each, in trial order
        std::vector<Eigen::VectorXd> pending(xs.begin() + (told - told0), xs.end());  // trials told..k-1
        const Eigen::VectorXd x = optimizer->ask(1, pending).front();
        points.push_back(x);
        xs.push_back(x);
      }
      while (told < told0 + static_cast<int>(tells.size())) tell_next();
      if (!tells.empty()) fitted.emplace(snapshot_of(*optimizer, told_trials), bo::model_state_to_json(optimizer->model_state()));
    } catch (const std::exception& e) {
      error = e.what();
    }
    return model_job_result(id, ask, std::move(fitted), std::move(points), error);
  };
  models_.submit(static_cast<std::uint64_t>(id), std::move(work));
}

void Coordinator::start_model_job(Study& s, int ask) {
  if (s.config.lockstep > 0) return start_lockstep_model_job(s, ask);
  // Everything the job needs is copied now: it runs while the event thread goes on changing the study.
  std::vector<bo::Observation> tells;
  for (auto& [trial_id, observation] : s.untold) {
    s.told_trials.push_back(trial_id);  // the order the optimizer will hold them in
    tells.push_back(std::move(observation));
  }
  s.untold.clear();
  std::vector<Eigen::VectorXd> pending;  // points being evaluated or about to be: the liar's lies
  for (const auto& [trial_id, f] : s.in_flight) pending.push_back(f.x);
  pending.insert(pending.end(), s.proposed.begin(), s.proposed.end());
  use_idle_model_threads(s);
  s.model_busy = true;
  s.asking = ask;
  const int id = s.id;
  auto work = [this, id, optimizer = s.optimizer, told_trials = s.told_trials, tells = std::move(tells),
               pending = std::move(pending), ask]() -> ModelPool::Completion {
    if (options_.model_job_hook) options_.model_job_hook(id);
    std::vector<Eigen::VectorXd> points;
    std::string error;
    FittedModel fitted;  // what the event thread keeps and stores
    try {
      if (!tells.empty()) {
        optimizer->tell_batch(tells);  // one fit for every report since the last job
        fitted.emplace(snapshot_of(*optimizer, told_trials), bo::model_state_to_json(optimizer->model_state()));
      }
      if (ask > 0) points = optimizer->ask(ask, pending);
    } catch (const std::exception& e) {
      error = e.what();  // e.g. a GP that cannot be factorised: logged, and the study asks again next tick
    }
    return model_job_result(id, ask, std::move(fitted), std::move(points), error);
  };
  models_.submit(static_cast<std::uint64_t>(id), std::move(work));
}

void Coordinator::use_idle_model_threads(Study& s) {
  // A job's acquisition search spreads over more threads only when fewer studies have jobs than there are
  // model threads (one study on two cores, say); otherwise the other studies' jobs fill the cores anyway,
  // and helper threads would only compete with them. Safe here: no job of this study is running.
  const int busy = static_cast<int>(std::count_if(studies_.begin(), studies_.end(),
                                                  [](const auto& kv) { return kv.second.model_busy; }));
  s.optimizer->set_threads(busy + 1 < std::max(options_.model_threads, 1) ? options_.acquisition_threads : 1);
}

int Coordinator::apply_model_results() { return models_.run_finished(); }

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
  Study* s = find_study(r.id.study_id);
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
  const Eigen::VectorXd x = it->second.x;
  const bool validation = it->second.validation;
  if (!store_.complete_trial(r, wall_now())) {
    info_(fmt::format("ignored a duplicate {} (already in the store)", what));
    return;
  }
  pool_.release(it->second.worker_id, s->id, trial_id);
  const domain::Candidate retired = make_candidate(*s, trial_id, it->second);
  s->in_flight.erase(it);
  if (validation) {
    account_validation(*s, trial_id, r);
  } else {
    count_report(*s, trial_id, x, r);
  }
  out_.retire_candidate(retired);
  if (!s->records_retired) out_.publish_trial(make_trial_record(*s, trial_id, x, r));  // else: the store has it
  if (!r.ok()) warn_(fmt::format("study {} trial {}: rollout failed on {}: {}", s->id, trial_id, r.worker_id, r.error));
  fail_on_failure_streak(*s, r);
  finish_if_complete(*s);
  if (!is_open(*s)) publish_state(*s, now_s);
}

void Coordinator::count_report(Study& s, int trial_id, const Eigen::VectorXd& x, const domain::RolloutReport& r) {
  s.untold.emplace_back(trial_id, bo::Observation{x, r.ok() ? r.summary.cost : 0.0, !r.ok(), r.ok() && r.fell(),
                                                  !r.ok() && domain::reissued_not_spent(r.outcome)});
  account_report(s, trial_id, x, r);
}

void Coordinator::account_report(Study& s, int trial_id, const Eigen::VectorXd& x, const domain::RolloutReport& r) {
  ++s.completed;
  if (!count_outcome(s, r)) return;
  if (!(r.summary.cost >= s.best_cost)) {  // also true while best_cost is NaN
    s.best_cost = r.summary.cost;
    s.best_trial = trial_id;
    s.best_params = s.config.space.to_named(x);
    s.best_x = x;
    s.best_normalized_torque = r.summary.normalized_torque;
    s.best_speed_mps = r.summary.mean_speed_mps;
  }
}

void Coordinator::finish_if_complete(Study& s) {
  if (s.state != StudyStatus::kRunning || s.completed < s.config.budget) return;
  const auto& v = s.config.validation;
  if (v.enabled && (!s.validation_started || s.validated < v.hardware_sets)) return;  // the hardware phase
  s.state = StudyStatus::kDone;
  s.message = fmt::format("{} rollouts, best cost {:.4g} (trial {})", s.completed, s.best_cost, s.best_trial);
  if (v.enabled) s.message += fmt::format("; {} validation sets run on hardware", s.validated);
  store_.set_state(s.id, to_string(s.state), s.message);
  info_(fmt::format("study {} '{}' done: {}", s.id, s.name, s.message));
  s.dirty = true;
}

domain::TrialRecord Coordinator::make_trial_record(const Study& s, int trial_id, const Eigen::VectorXd& x,
                                                   const domain::RolloutReport& r) const {
  domain::TrialRecord t;
  t.study_id = s.id;
  t.trial_id = trial_id;
  t.initial = trial_id < s.config.optimizer.initial_points;
  t.parameters = s.config.space.to_named(x);
  t.report = r;
  t.report.id.study_id = s.id;
  t.report.id.trial_id = trial_id;
  return t;
}

// ---- time ----------------------------------------------------------------------------------------

void Coordinator::publish_state(Study& s, double now_s) {
  domain::StudyState st;
  st.study_id = s.id;
  st.name = s.name;
  st.status = s.state;
  // Both phases count: budget = exploration budget + validation sets, completed = reports of either.
  const int sets = s.config.validation.enabled ? s.config.validation.hardware_sets : 0;
  st.budget = s.config.budget + sets;
  st.completed = s.completed + s.validated;
  st.in_flight = static_cast<int>(s.in_flight.size());
  st.failed = s.failed;
  st.falls = s.falls;
  st.reissued = s.reissued;
  st.workers = pool_.size();
  st.best_cost = s.best_cost;
  st.best_trial = s.best_trial;
  st.best_params = s.best_params;
  st.best_normalized_torque = s.best_normalized_torque;
  st.best_speed_mps = s.best_speed_mps;
  // Wall time, as created_at_s is (it survives restarts): after the clock is stepped back past a study's
  // creation, 0 rather than a negative age.
  st.elapsed_s = std::max(0.0, wall_now() - s.created_at_s);
  const double session = now_s - s.session_start_s;
  st.rollouts_per_s = session > 0.0 ? (s.completed - s.completed_at_session_start) / session : 0.0;
  st.message = s.message;
  if (s.model.has_recommendation) {
    st.has_recommendation = true;
    st.recommendation = domain::Recommendation{s.model.recommended_trial, s.model.recommended_predicted_cost,
                                               s.model.recommended_params};
  }
  out_.publish_state(st);
  s.dirty = false;
  last_state_publish_[s.id] = now_s;
}

void Coordinator::retire_finished(Study& s, double now_s) {
  if (is_open(s) || s.records_retired) return;
  if (s.records_leave_at_s < 0.0) s.records_leave_at_s = now_s + options_.finished_records_grace_s;
  if (now_s < s.records_leave_at_s || s.model_busy || !s.untold.empty()) return;
  std::vector<int> records = s.told_trials;
  records.insert(records.end(), s.validation_trials.begin(), s.validation_trials.end());
  for (const int trial_id : records) {
    domain::TrialRecord key;
    key.study_id = s.id;
    key.trial_id = trial_id;
    out_.retire_trial(key);
  }
  s.records_retired = true;
  // Its spec leaves the topic too, unless another open study runs the same spec.
  const bool shared = std::any_of(studies_.begin(), studies_.end(), [&](const auto& kv) {
    return kv.second.id != s.id && is_open(kv.second) && kv.second.spec && kv.second.spec->key() == s.spec->key();
  });
  if (!shared && s.spec) out_.retire_spec(spec_sample(s));
  release_optimizer_if_done(s);
}

void Coordinator::tick(double now_s) {
  issues_left_this_tick_ = std::max(1, options_.max_issues_per_tick);
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
  const std::vector<Study*> order = round_robin_order();
  start_model_jobs(order, issue_waiting_work(order, now_s));
  // Without model threads the jobs just started have finished already: issue their points now.
  if (apply_model_results() > 0) issue_waiting_work(order, now_s);
  bool validation_started = false;
  for (Study* s : order) validation_started |= start_validation_if_due(*s);
  if (validation_started) issue_waiting_work(order, now_s);
  for (Study* s : order) {
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
