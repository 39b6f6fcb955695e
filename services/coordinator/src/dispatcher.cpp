#include "cpgmatch/service/dispatcher.hpp"

#include <algorithm>

namespace cpgmatch::service {

FreeSlots Dispatcher::issue_waiting_work(const std::vector<StudyRun*>& order, double now_s) {
  struct Slots {
    std::vector<PoolWorker*> slots;
    std::size_t next = 0;
    int free() const { return static_cast<int>(slots.size() - next); }
    // Moves the free slots this study may use to the front (in their order) and says how many there are:
    // a worker within a refusal's backoff for this study serves the other studies meanwhile.
    int usable_for(const StudyRun& study, double now) {
      const auto first = slots.begin() + static_cast<std::ptrdiff_t>(next);
      const auto end = std::stable_partition(first, slots.end(), [&](const PoolWorker* w) { return study.may_serve(*w, now); });
      return static_cast<int>(end - first);
    }
  };
  Slots sim{pool_.free_slots(false)}, hw{pool_.free_slots(true)};
  // Every candidate written this tick counts against max_issues_per_tick (the DDS writes of a full fill
  // would stall the event loop, see CoordinatorOptions), whichever kind of slot it goes to: a tick that
  // reaches the cap leaves the other slots free for the next ticks, and they still count as free below.
  for (StudyRun* s : order) {
    if (s->state != StudyStatus::kRunning) continue;
    Slots& explore = s->explores_on_hardware() ? hw : sim;
    // Re-issues (and stored validation sets and hardware proposals) first: they are the oldest work.
    for (auto& [trial_id, f] : s->in_flight) {
      if (!f.worker_id.empty()) continue;
      Slots& kind = f.hardware_only() ? hw : explore;
      if (issues_left_ <= 0 || kind.usable_for(*s, now_s) == 0) continue;
      issue(*s, trial_id, *kind.slots[kind.next++], now_s, !f.issued_to.empty());
      --issues_left_;
    }
    const std::size_t before = explore.next;
    const int usable = explore.usable_for(*s, now_s);
    issue_proposed(*s, explore.slots, explore.next, std::max(0, std::min(issues_left_, usable)), now_s);
    issues_left_ -= static_cast<int>(explore.next - before);
  }
  return {sim.free(), hw.free()};
}

void Dispatcher::issue_proposed(StudyRun& s, std::vector<PoolWorker*>& slots, std::size_t& next_slot, int max_count,
                                 double now_s) {
  std::vector<study::StoredTrial> stored;
  while (!s.proposed.empty() && next_slot + stored.size() < slots.size() &&
         static_cast<int>(stored.size()) < max_count) {
    study::StoredTrial t;
    t.trial_id = s.next_trial_id++;
    t.x = std::move(s.proposed.front());
    s.proposed.pop_front();
    t.worker_id = slots[next_slot + stored.size()]->id;
    t.issued_at_s = wall_now_();
    stored.push_back(std::move(t));
  }
  if (stored.empty()) return;
  store_.add_trials(s.id, stored);  // committed before anything is published
  for (const auto& t : stored) {
    s.in_flight[t.trial_id] = InFlight{t.x, 0, "", 0.0, {}};
    issue(s, t.trial_id, *slots[next_slot++], now_s, false);
  }
}

void Dispatcher::issue(StudyRun& study, int trial_id, PoolWorker& worker, double now_s, bool reissue) {
  InFlight& f = study.in_flight.at(trial_id);
  if (reissue) {
    ++f.attempt;
    store_.reissue(study.id, trial_id, f.attempt, worker.id, wall_now_());
  } else if (f.hardware_only() || f.enqueued) {
    // Stored without a worker (a validation set at the phase's start, a hardware proposal when the model
    // made it, a queued gait): record who has it, so a restart after this point still accepts its report.
    store_.reissue(study.id, trial_id, f.attempt, worker.id, wall_now_());
  }
  f.worker_id = worker.id;
  f.issued_to[f.attempt] = worker.id;
  f.deadline_s = now_s + study.config.effective_lease_s();
  pool_.assign(worker.id, study.id, trial_id);
  out_.send_candidate(study.candidate(store_.store_id(), trial_id));
  study.dirty = true;
}

}  // namespace cpgmatch::service
