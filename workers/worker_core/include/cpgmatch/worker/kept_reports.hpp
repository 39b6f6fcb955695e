// The reports a worker has written and the optimizer has not yet acknowledged. Reports stay in the
// writer's transient-local history so that an optimizer restarting mid-study still receives them; the
// optimizer disposes a candidate once its report is in the store, and that dispose is the
// acknowledgement: the worker then unregisters the report, which frees it in its writer and the
// instance in the optimizer's reader. An optimizer that never acknowledges (lost, or an old one) would
// make the writer grow for ever, so beyond `limit` the oldest are unregistered anyway.
//
// No DDS entities here: the methods return which reports to unregister (their attempt ids: the topic's key
// is store, study and trial) and the DDS shell (worker_link.hpp) does it. Not thread-safe: the shell calls it under the lock it writes reports with.
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <map>
#include <optional>
#include <tuple>
#include <vector>

#include "cpgmatch/domain/rollout_report.hpp"

namespace cpgmatch::worker {

inline constexpr std::size_t kReportsKept = 4096;

class KeptReports {
 public:
  explicit KeptReports(std::size_t limit = kReportsKept);

  // A report was written. Returns those to unregister now: the oldest unacknowledged ones beyond the
  // limit (at most one per call once the limit is reached).
  std::vector<domain::AttemptId> keep(const domain::AttemptId& report);

  // The candidate with `key`'s key fields (store, study, trial) was disposed: its report, if still
  // kept, to unregister.
  std::optional<domain::AttemptId> acknowledge(const domain::AttemptId& key);

  std::size_t size() const { return kept_.size(); }

 private:
  using ReportKey = std::tuple<std::uint64_t, int, int>;  // the topic's key: store, study, trial
  std::size_t limit_;
  std::map<ReportKey, domain::AttemptId> kept_;   // written, not yet acknowledged
  std::deque<ReportKey> order_;                   // in writing order; may name acknowledged ones
};

}  // namespace cpgmatch::worker
