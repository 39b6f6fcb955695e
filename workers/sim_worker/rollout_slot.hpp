// What one worker slot does with its candidates, one at a time: validate each, run its rollout in the
// slot's rollout process (or a fixed delay for service benchmarks) and turn the outcome into a report.
// Never throws for a bad candidate or a crashing rollout: those become reports that did not measure, with
// the reason. Domain types only: the worker's link (worker_link.hpp) converts to and from the wire.
//
// The rollout process (`cpgmatch-sim-worker --serve-rollouts`, rollout_server.hpp) is kept between
// candidates, and is sent each study's spec once; isolation stays: when it crashes, hangs past the
// candidate's lease or answers with something that is no answer, that candidate's report says so, the
// process is killed and reaped, and the next candidate gets a fresh one.
#pragma once

#include <sys/types.h>

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "cpgmatch/domain/candidate.hpp"
#include "cpgmatch/domain/rollout_report.hpp"
#include "cpgmatch/line_process.hpp"
#include "cpgmatch/study/study_spec.hpp"

namespace cpgmatch::worker {

// The spec a candidate names, or why to refuse it (the worker's SpecBook::find).
struct SpecLookup {
  std::shared_ptr<const study::StudySpec> spec;  // null: refuse, for `refusal`
  std::string refusal;
};

struct SlotOptions {
  std::string worker_id;
  double fake_rollout_s = -1.0;  // >= 0: no simulation, sleep this long and report a synthetic cost
  std::function<SpecLookup(std::uint64_t spec_key)> find_spec;
  // The rollout process's command line; empty: this executable with --serve-rollouts.
  std::vector<std::string> rollout_command;
};

class RolloutSlot {
 public:
  explicit RolloutSlot(SlotOptions options);

  // Validates, runs and reports one candidate. Call from one thread: the rollout process dies with the
  // thread that started it (PR_SET_PDEATHSIG).
  domain::RolloutReport execute(const domain::Candidate& c);

  // Starts the rollout process now if none runs (nothing for fake rollouts), so that the next candidate
  // does not wait for a process to start: at the slot's start, and after a candidate that cost the process.
  // A process that cannot be started now is tried again by the next candidate.
  void prepare();

  // The rollout's own run time, as its process measured it, of the last candidate that ran (benchmarks:
  // the report's wall_time_s is the whole time in the slot).
  double last_rollout_run_s() const { return last_rollout_run_s_; }
  pid_t rollout_process_id() const { return process_.pid(); }  // 0: none running (tests)

 private:
  // The report of the rollout process's answer, or none and why (`failure`, in the report's words).
  std::optional<domain::RolloutReport> run_in_rollout_process(const domain::Candidate& c, const study::StudySpec& spec,
                                                              std::string& failure);

  SlotOptions options_;
  LineProcess process_;
  // The specs the current rollout process was sent (it may have evicted some since: it says so).
  std::set<std::uint64_t> specs_sent_;
  std::uint64_t specs_sent_to_ = 0;  // the process generation they were sent to
  double last_rollout_run_s_ = 0.0;
};

}  // namespace cpgmatch::worker
