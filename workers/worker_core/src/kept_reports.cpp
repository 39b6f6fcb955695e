#include "cpgmatch/worker/kept_reports.hpp"

#include <stdexcept>

namespace cpgmatch::worker {

KeptReports::KeptReports(std::size_t limit) : limit_(limit) {
  if (limit_ == 0) throw std::logic_error("KeptReports: the limit must be at least 1");
}

std::vector<domain::AttemptId> KeptReports::keep(const domain::AttemptId& report) {
  const ReportKey key{report.store_id, report.study_id, report.trial_id};
  // A second report for the same key (a re-issued attempt) replaces the first in the writer too: the
  // topic keeps one sample per instance.
  kept_[key] = report;
  order_.push_back(key);
  if (order_.size() > 2 * limit_) {  // acknowledged keys accumulate in the order: drop them now and then
    std::deque<ReportKey> live;
    for (const auto& k : order_) {
      if (kept_.count(k)) live.push_back(k);
    }
    order_.swap(live);
  }
  std::vector<domain::AttemptId> released;
  while (kept_.size() > limit_) {
    if (const auto oldest = kept_.find(order_.front()); oldest != kept_.end()) {
      released.push_back(oldest->second);
      kept_.erase(oldest);
    }
    order_.pop_front();
  }
  return released;
}

std::optional<domain::AttemptId> KeptReports::acknowledge(const domain::AttemptId& key) {
  const auto it = kept_.find({key.store_id, key.study_id, key.trial_id});
  if (it == kept_.end()) return std::nullopt;
  const domain::AttemptId report = it->second;
  kept_.erase(it);
  return report;
}

}  // namespace cpgmatch::worker
