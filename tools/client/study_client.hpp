// A DDS client of the optimizer service for the command line: sends commands and reads study states,
// workers and trial records. The interface is plain C++ and JSON (pimpl), so the CLI code does not
// include Fast DDS headers.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "cpgmatch/domain/command.hpp"

namespace cpgmatch::client {

struct CommandResult {
  bool ok = false;
  int study_id = 0;
  std::string message;
};

class StudyClient {
 public:
  // `read_trials`: also subscribe to trial records (the whole transient-local history). `read_workers`: to the
  // workers' announcements (workers(), wait_for_workers()); a client that does not list workers leaves it
  // off, since each worker's heartbeats would otherwise reach it too (a fleet of 80 cost a `study submit`
  // about 800 datagrams, tests/bench/scale_out.sh).
  StudyClient(int domain, bool localhost_only, bool read_trials = false, bool read_workers = true);
  ~StudyClient();
  StudyClient(const StudyClient&) = delete;
  StudyClient& operator=(const StudyClient&) = delete;

  // Both wait up to `timeout_s` for an optimizer and its reply; throw std::runtime_error when none answers.
  // `enqueue`: the gaits of the study file's `enqueue:` files (the client reads them, the service cannot).
  CommandResult submit(const std::string& study_yaml, const std::string& source_name, double timeout_s,
                       const std::vector<domain::EnqueuedGait>& enqueue = {});
  // kind: pause | resume | stop
  CommandResult control(const std::string& kind, int study_id, double timeout_s);
  // A stopped or finished study continues with `added_trials` more (docs/steering.md).
  CommandResult extend(int study_id, int added_trials, double timeout_s);
  // Known gaits run as the study's next trials.
  CommandResult enqueue(int study_id, const std::vector<domain::EnqueuedGait>& gaits, double timeout_s);

  // True once an optimizer's state writer is matched; then waits `settle_s` for its history to arrive.
  bool wait_for_optimizer(double timeout_s, double settle_s = 1.0);
  // Waits until a worker's announcement writer is matched (up to `timeout_s`), then until every matched one has
  // been heard (up to two heartbeat periods), so that `workers` lists every worker that heartbeats, not only
  // those whose announcement happened to arrive in time. False when no worker was found.
  bool wait_for_workers(double timeout_s);
  // Workers whose announcement writer this client has matched (heard or not yet).
  int matched_workers() const;
  // The live workers the optimizer counts (its study states say so); nothing when no state arrived.
  std::optional<int> optimizer_worker_count() const;
  // True once the state of `study_id` has arrived (transient-local history can lag the match).
  bool wait_for_study(int study_id, double timeout_s);

  std::map<int, nlohmann::json> states() const;             // latest state per study (to_json(StudyState))
  std::map<std::string, nlohmann::json> workers() const;    // live workers by id
  std::vector<nlohmann::json> trials(int study_id) const;   // trial records by trial id
  // Grows with every state, worker or trial sample taken in: equal revisions, equal views (nothing to redraw).
  std::uint64_t revision() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace cpgmatch::client
