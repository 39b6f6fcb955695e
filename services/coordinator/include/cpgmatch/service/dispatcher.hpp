// Which work goes to which free worker slot, and the issuing of candidates. Every tick the Coordinator hands
// the dispatcher its running studies in round-robin order; the dispatcher gives each study's re-issues (and
// stored validation sets and hardware proposals, to hardware slots only) first, then its proposed points, to the free slots of the kind the work needs and
// that may serve the study (its robot, no refusal backoff), and writes each candidate after the store holds
// it. A tick writes at most max_issues candidates (each DDS write costs the event thread about a millisecond;
// CoordinatorOptions::max_issues_per_tick), the rest waits for the next ticks.
#pragma once

#include <functional>
#include <vector>

#include "cpgmatch/service/outbox.hpp"
#include "cpgmatch/service/study_run.hpp"
#include "cpgmatch/service/worker_pool.hpp"
#include "cpgmatch/study/study_store.hpp"

namespace cpgmatch::service {

struct FreeSlots {
  int simulation = 0;
  int hardware = 0;
};

class Dispatcher {
 public:
  // `wall_now` gives the Unix time the store records issues with.
  Dispatcher(study::StudyStore& store, Outbox& out, WorkerPool& pool, std::function<double()> wall_now)
      : store_(store), out_(out), pool_(pool), wall_now_(std::move(wall_now)) {}

  // A new tick: at most `max_issues` candidates are written until the next one (at least 1).
  void start_tick(int max_issues) { issues_left_ = std::max(1, max_issues); }
  // Re-issues, then proposed points, of the running studies in `order`; returns the slots still free
  // (slots the cap kept empty count as free: the model is asked for their points already).
  FreeSlots issue_waiting_work(const std::vector<StudyRun*>& order, double now_s);

 private:
  // Stores the study's proposed points as trials (one transaction) and issues them to the slots from next_slot.
  void issue_proposed(StudyRun& study, std::vector<PoolWorker*>& slots, std::size_t& next_slot, int max_count,
                      double now_s);
  // Gives a trial in flight to a worker (a new attempt when it was issued before) and writes its candidate.
  void issue(StudyRun& study, int trial_id, PoolWorker& worker, double now_s, bool reissue);

  study::StudyStore& store_;
  Outbox& out_;
  WorkerPool& pool_;
  std::function<double()> wall_now_;
  int issues_left_ = 0;
};

}  // namespace cpgmatch::service
