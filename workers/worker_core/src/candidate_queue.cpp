#include "cpgmatch/worker/candidate_queue.hpp"

#include <utility>

namespace cpgmatch::worker {

CandidateQueue::CandidateQueue(std::string worker_id) : worker_id_(std::move(worker_id)) {}

CandidateQueue::IssueKey CandidateQueue::issue_key(const domain::Candidate& c) {
  return {c.id.store_id, c.id.study_id, c.id.trial_id, c.id.attempt};
}

const char* CandidateQueue::to_string(Offer offer) {
  switch (offer) {
    case Offer::kQueued: return "queued";
    case Offer::kNotOurs: return "not ours";
    case Offer::kDuplicate: return "duplicate (this issue is queued or running)";
    case Offer::kDraining: return "dropped (shutting down)";
  }
  return "?";
}

CandidateQueue::Offer CandidateQueue::offer(const domain::Candidate& c) {
  // The worker's reader delivers every candidate on the domain: this is where a worker keeps its own, so
  // it never runs (and the optimizer never rejects a report for) another worker's candidate.
  if (c.worker_id != worker_id_) return Offer::kNotOurs;
  std::lock_guard<std::mutex> lock(mutex_);
  if (draining_) return Offer::kDraining;
  // Dropped only while the very same issue is queued or running: a re-issue (a higher attempt, e.g.
  // after our report was lost) runs again, and so does a trial of a fresh store that reuses ids seen long
  // ago. The optimizer counts each trial once anyway.
  if (!in_progress_.insert(issue_key(c)).second) return Offer::kDuplicate;
  queue_.push_back(c);
  wake_.notify_one();
  return Offer::kQueued;
}

std::optional<domain::Candidate> CandidateQueue::take() {
  std::unique_lock<std::mutex> lock(mutex_);
  wake_.wait(lock, [&] { return draining_ || !queue_.empty(); });
  if (draining_) return std::nullopt;
  domain::Candidate c = std::move(queue_.front());
  queue_.pop_front();
  ++busy_;
  return c;
}

void CandidateQueue::finish(const domain::Candidate& c) {
  std::lock_guard<std::mutex> lock(mutex_);
  in_progress_.erase(issue_key(c));
  if (busy_ > 0) --busy_;
  ++completed_;
}

std::size_t CandidateQueue::drain() {
  std::lock_guard<std::mutex> lock(mutex_);
  const std::size_t dropped = queue_.size();
  for (const auto& c : queue_) in_progress_.erase(issue_key(c));
  queue_.clear();
  draining_ = true;
  wake_.notify_all();
  return dropped;
}

CandidateQueue::Load CandidateQueue::load() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return Load{busy_, completed_, queue_.size()};
}

}  // namespace cpgmatch::worker
