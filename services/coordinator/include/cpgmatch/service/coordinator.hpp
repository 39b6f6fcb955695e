// The optimizer service's logic, free of DDS entities: wire samples come in through handle_*(), and
// everything to publish goes out through an Outbox. The DDS shell (services/optimizer_main.cpp) only
// moves samples between the two; tests drive a Coordinator directly with a recording Outbox.
//
// Rules it keeps:
//  * store first: a candidate is in the store before it is published, a report before it is told to the
//    optimizer or published as a trial record; a restart on the same store resumes every study.
//  * exactly once: the first valid report for an in-flight trial counts; later ones are ignored.
//  * every live worker slot is kept busy: free slots are filled with ask(n) batches, round-robin over
//    running studies, re-issued candidates first.
//  * nothing malformed gets in: a bad sample is logged with its reason and dropped.
#pragma once

#include <cmath>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "cpgmatch/bo/optimizer.hpp"
#include "cpgmatch/params.hpp"
#include "cpgmatch/study/study_config.hpp"
#include "cpgmatch/study/study_store.hpp"
#include "cpgmatch_msgs.h"

namespace cpgmatch::service {

class Outbox {
 public:
  virtual ~Outbox() = default;
  virtual void send_candidate(const msg::Candidate& c) = 0;
  virtual void retire_candidate(const msg::Candidate& c) = 0;  // report received: drop it from the topic
  virtual void publish_trial(const msg::TrialRecord& t) = 0;
  virtual void publish_state(const msg::StudyState& s) = 0;
  virtual void reply(const msg::CommandReply& r) = 0;
};

struct CoordinatorOptions {
  double worker_timeout_s = 2.5;       // no announcement for this long: the worker is gone
  int max_consecutive_failures = 10;   // rollouts that could not run in a row before a study fails
  // New proposals per tick, over all studies. A worker announcing thousands of slots is filled over several
  // ticks (every 20 ms) instead of one ask() that blocks the event loop for seconds; heartbeats, reports
  // and commands are served in between.
  int max_new_candidates_per_tick = 32;
  CpgParameters base_parameters;       // values of CPG parameters a study neither optimises nor fixes
  // Every `now_s` handed to the coordinator is *monotonic* time (timeouts and leases must not fire, or
  // hang, when the wall clock is stepped); this clock gives the Unix time written to the store and shown
  // as a study's age. Empty: the system clock.
  std::function<double()> wall_clock_s;
};

using LogFn = std::function<void(const std::string&)>;

class Coordinator {
 public:
  Coordinator(study::StudyStore& store, Outbox& outbox, CoordinatorOptions options, LogFn log_info,
              LogFn log_warning);

  // Reloads every study from the store: observations replayed, in-flight candidates queued for
  // re-issue, trial records and states published again.
  void resume_from_store(double now_s);

  void handle_command(const msg::StudyCommand& command, double now_s);
  void handle_report(const msg::RolloutReport& report, double now_s);
  void handle_worker(const msg::WorkerAnnouncement& announcement, double now_s);
  void handle_worker_gone(std::uint64_t worker_key, double now_s);
  // Expires silent workers and overdue leases, fills free slots, publishes changed study states.
  void tick(double now_s);

  // Numbers for logs and tests.
  int live_workers() const { return static_cast<int>(workers_.size()); }
  int studies() const { return static_cast<int>(studies_.size()); }
  bool idle() const;  // no running study has work left
  std::uint64_t rejected_samples() const { return rejected_; }

 private:
  struct InFlight {
    Eigen::VectorXd x;
    int attempt = 0;
    std::string worker_id;  // empty: waiting for a free slot
    double deadline_s = 0.0;
    // The worker each attempt was issued to: only that worker's report for that attempt counts, so a
    // participant that merely reads candidates cannot answer them.
    std::map<int, std::string> issued_to;
  };
  struct Study {
    int id = 0;
    std::string name;
    study::StudyConfig config;
    std::unique_ptr<bo::BayesianOptimizer> optimizer;
    std::map<int, InFlight> in_flight;   // by trial id
    std::vector<int> told_trials;        // trial id of each optimizer observation, in the order told
    int next_trial_id = 0;
    int completed = 0, failed = 0, falls = 0, reissued = 0, consecutive_failures = 0;
    std::string state = "running";
    std::string message;
    double best_cost = std::nan("");
    int best_trial = 0;
    std::map<std::string, double> best_params;
    double best_normalized_torque = std::nan(""), best_speed_mps = std::nan("");
    double created_at_s = 0.0, session_start_s = 0.0;
    int completed_at_session_start = 0;
    bool dirty = true;
  };
  struct Worker {
    std::string id;
    std::uint64_t key = 0;
    int slots = 0;
    bool accepting = true;
    double last_seen_s = 0.0;
    std::set<std::pair<int, int>> assigned;  // (study, trial)
  };

  void reject(const std::string& what, const std::string& why);
  void submit(const msg::StudyCommand& command, double now_s, msg::CommandReply& reply);
  Study* find_study(int study_id);
  void open_study(Study&& study, const study::StoredStudy* stored, double now_s);
  void drop_worker(const std::string& worker_id, const std::string& why, double now_s);
  void unassign(Study& study, int trial_id, const std::string& why);
  void fill_free_slots(double now_s);
  void issue(Study& study, int trial_id, Worker& worker, double now_s, bool reissue);
  // A new report: told to the optimizer (whose state is then saved), then accounted.
  void count_report(Study& study, int trial_id, const Eigen::VectorXd& x, const msg::RolloutReport& report);
  // Counters and best of a report the optimizer already holds (a restart's replay).
  void account_report(Study& study, int trial_id, const Eigen::VectorXd& x, const msg::RolloutReport& report);
  // The study's optimizer from its stored observations: restored from the saved model state (one
  // factorisation), or replayed observation by observation when there is none.
  bo::BayesianOptimizer restored_optimizer(const Study& study, const study::StoredStudy* stored,
                                           const std::vector<bo::Observation>& observations) const;
  void finish_if_complete(Study& study);
  msg::Candidate make_candidate(const Study& study, int trial_id, const InFlight& f) const;
  msg::TrialRecord make_trial_record(const Study& study, int trial_id, const Eigen::VectorXd& x,
                                     const msg::RolloutReport& report) const;
  void publish_state(Study& study, double now_s);
  bool is_open(const Study& s) const { return s.state == "running" || s.state == "paused"; }

  study::StudyStore& store_;
  Outbox& out_;
  CoordinatorOptions options_;
  LogFn info_, warn_;
  double wall_now() const;  // Unix time, for the store
  std::map<int, Study> studies_;
  std::map<std::string, Worker> workers_;
  std::map<int, double> last_state_publish_;
  // Replies by (client_id, correlation_id): a client re-sends a command whose reply it did not get, and
  // gets the same reply again instead of a second execution (a second study, say). Last kMaxReplies.
  std::map<std::pair<std::string, std::uint64_t>, msg::CommandReply> replies_;
  std::deque<std::pair<std::string, std::uint64_t>> reply_order_;
  int round_robin_ = 0;
  std::uint64_t rejected_ = 0;
};

}  // namespace cpgmatch::service
