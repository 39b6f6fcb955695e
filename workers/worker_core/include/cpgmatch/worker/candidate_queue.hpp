// The candidates a worker has accepted and not yet reported: what the simulation worker's slots and the
// robot agent's rollout thread both take their work from. No DDS entities here (the DDS shell,
// worker_link.hpp, offers what its reader receives), so the rules below are tested without a network.
//
//   CandidateQueue queue("node12");
//   reader callback:  queue.offer(candidate);
//   rollout thread:   while (auto c = queue.take()) { report = run(*c); write(report); queue.finish(*c); }
//   shutdown:         queue.drain();   // every take() returns nullopt, queued candidates are dropped
//
// Thread-safe: offer() runs on a DDS listener thread, take()/finish() on the rollout threads, load() on
// the heartbeat thread.
#pragma once

#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <tuple>

#include "cpgmatch/domain/candidate.hpp"

namespace cpgmatch::worker {

class CandidateQueue {
 public:
  explicit CandidateQueue(std::string worker_id);

  enum class Offer {
    kQueued,     // it will run
    kNotOurs,    // addressed to another worker: every worker reads every candidate (worker_link.hpp)
    kDuplicate,  // the very same issue is queued or running: DDS delivered it twice
    kDraining,   // shutting down: the optimizer re-issues it once this worker has left the domain
  };
  Offer offer(const domain::Candidate& c);
  static const char* to_string(Offer offer);  // "queued", "not ours", "duplicate", "draining" (for logs)

  // The oldest queued candidate, now counted as running; blocks until there is one. nullopt once
  // drain() was called: the caller's loop ends.
  std::optional<domain::Candidate> take();

  // Its report has been written: the issue is no longer running (a later delivery of the same issue is
  // accepted again) and counts as completed.
  void finish(const domain::Candidate& c);

  // Stops accepting, drops the queued candidates and wakes every take(). Returns how many were dropped
  // (handed back: the optimizer re-issues them). Running candidates still finish.
  std::size_t drain();

  struct Load {
    std::uint32_t busy = 0;        // taken, not finished
    std::uint64_t completed = 0;   // finished since start
    std::size_t queued = 0;
  };
  Load load() const;

 private:
  // What identifies one issue of a trial: store, study, trial, attempt. A re-issue (higher attempt) or
  // a fresh store reusing old ids is new work; the same issue delivered twice is not.
  using IssueKey = std::tuple<std::uint64_t, int, int, int>;
  static IssueKey issue_key(const domain::Candidate& c);

  const std::string worker_id_;
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<domain::Candidate> queue_;
  std::set<IssueKey> in_progress_;  // queued or running: bounded by the queue and the slots
  std::uint32_t busy_ = 0;
  std::uint64_t completed_ = 0;
  bool draining_ = false;
};

}  // namespace cpgmatch::worker
