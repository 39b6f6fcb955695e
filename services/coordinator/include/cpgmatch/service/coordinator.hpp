// The optimizer service's logic, free of DDS: domain values (services/domain) come in through handle_*(),
// and everything to publish goes out through an Outbox, also as domain values. The DDS shell
// (services/optimizer_service/main.cpp) converts samples with idl/transport's from_wire/to_wire and moves
// them between the two; tests drive a Coordinator directly with a recording Outbox.
//
// Threads: every public member runs on one thread (the event thread), which owns the store and all
// bookkeeping. Model work (a study's tells with their GP fit, its asks with their acquisition
// optimisation) runs as jobs on a ModelPool: one job per study at a time, so a study's tells are applied
// in report order before its next ask, whatever the thread timing; different studies' jobs run in
// parallel. Results come back through tick() (or apply_model_results()).
//
// Rules it keeps:
//  * store first: a candidate is in the store before it is published, a report before it is told to the
//    optimizer or published as a trial record; a restart on the same store resumes every study.
//  * exactly once: the first valid report for an in-flight trial counts; later ones are ignored.
//  * every live worker slot is kept busy: free slots are filled with ask(n) batches, round-robin over
//    running studies, re-issued candidates first.
//  * nothing malformed gets in: a bad sample is logged with its reason and dropped.
//  * work goes by worker kind: exploration candidates to the study's `explore_on` kind (simulation by
//    default), validation sets to hardware workers only. The validation phase (a study with a
//    `validation` key) starts once the exploration budget is reported and the model holds every report:
//    its N sets are stored at once (phase "validation"), so a restart issues the same sets. Validation
//    reports are never told to the optimizer: they measure the answer on hardware, they do not steer it.
//    No hardware worker on the domain: the study waits and says so in its state's message.
//  * a report counts only from the worker its attempt was issued to; with DDS-Security on
//    (CoordinatorOptions::require_authenticated_workers) also only when that worker id belongs to the
//    sender's certificate (its CN, or CN/suffix: domain::worker_id_belongs_to), and a participant may only
//    announce worker ids its certificate owns. The DDS shell hands in the sender's authenticated CN.
//  * a study owns its objective: its spec (study_spec.hpp) is resolved and stored at submit, published on
//    cpgmatch/study_specs while the study is open, and named by every candidate; workers run exactly it.
//  * a refused candidate is never a spent trial: a refusal (a latched emergency stop, a spec the worker
//    cannot run) re-issues it and keeps the study off that worker for a moment; a plant fault or a
//    diverged simulation re-issues it too, up to max_fault_retries faults, after which it is spent as a
//    failure the model never sees (bo::Observation::excluded).
//  * a slot count is a claim, not a right: a worker whose lease expired (it took a candidate and never
//    answered in time) is on probation, with at most one candidate at a time, until a report of its own
//    arrives for an attempt it was issued. Probation outlives the worker's leaving and rejoining.
#pragma once

#include <cmath>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "cpgmatch/bo/optimizer.hpp"
#include "cpgmatch/service/model_pool.hpp"
#include "cpgmatch/service/worker_pool.hpp"
#include "cpgmatch/params.hpp"
#include "cpgmatch/study/study_config.hpp"
#include "cpgmatch/study/study_spec.hpp"
#include "cpgmatch/study/study_store.hpp"
#include "cpgmatch/domain/candidate.hpp"
#include "cpgmatch/domain/command.hpp"
#include "cpgmatch/domain/rollout_report.hpp"
#include "cpgmatch/domain/study_state.hpp"
#include "cpgmatch/domain/study_status.hpp"
#include "cpgmatch/domain/worker_announcement.hpp"

namespace cpgmatch::service {

using domain::StudyStatus;

class Outbox {
 public:
  virtual ~Outbox() = default;
  virtual void send_candidate(const domain::Candidate& c) = 0;
  virtual void retire_candidate(const domain::Candidate& c) = 0;  // report received: drop it from the topic
  virtual void publish_trial(const domain::TrialRecord& t) = 0;
  // A finished study's record leaves the topic (its study and trial id are set; the store keeps the record).
  virtual void retire_trial(const domain::TrialRecord& t) = 0;
  virtual void publish_state(const domain::StudyState& s) = 0;
  virtual void reply(const domain::CommandReply& r) = 0;
  // An open study's spec on cpgmatch/study_specs, and its leaving once no open study uses it.
  virtual void publish_spec(const domain::SpecPublication&) {}
  virtual void retire_spec(const domain::SpecPublication&) {}
};

// Holds what the coordinator publishes while a store batch (study::StudyStore::Batch) is open, and
// passes it on, in order, once the batch has committed: a report is acknowledged (its candidate retired,
// its trial record published), a candidate sent or a command answered only after the store holds it, as
// when every write committed on its own. Not holding: passes everything straight on.
class DeferredOutbox final : public Outbox {
 public:
  explicit DeferredOutbox(Outbox& target) : target_(target) {}
  void hold() { holding_ = true; }
  // Sends everything held, in order, and stops holding.
  void release();
  // Drops everything held (the batch did not commit) and stops holding.
  void discard();
  std::size_t held() const { return held_.size(); }

  void send_candidate(const domain::Candidate& c) override { pass([c](Outbox& o) { o.send_candidate(c); }); }
  void retire_candidate(const domain::Candidate& c) override { pass([c](Outbox& o) { o.retire_candidate(c); }); }
  void publish_trial(const domain::TrialRecord& t) override { pass([t](Outbox& o) { o.publish_trial(t); }); }
  void retire_trial(const domain::TrialRecord& t) override { pass([t](Outbox& o) { o.retire_trial(t); }); }
  void publish_state(const domain::StudyState& s) override { pass([s](Outbox& o) { o.publish_state(s); }); }
  void reply(const domain::CommandReply& r) override { pass([r](Outbox& o) { o.reply(r); }); }
  void publish_spec(const domain::SpecPublication& s) override { pass([s](Outbox& o) { o.publish_spec(s); }); }
  void retire_spec(const domain::SpecPublication& s) override { pass([s](Outbox& o) { o.retire_spec(s); }); }

 private:
  void pass(std::function<void(Outbox&)> send) {
    if (holding_) held_.push_back(std::move(send));
    else send(target_);
  }
  Outbox& target_;
  bool holding_ = false;
  std::vector<std::function<void(Outbox&)>> held_;
};

struct CoordinatorOptions {
  double worker_timeout_s = 2.5;       // no announcement for this long: the worker is gone
  int max_consecutive_failures = 10;   // rollouts that could not run in a row before a study fails
  // New proposals per tick, over all studies. A worker announcing thousands of slots is filled over several
  // ticks (every 20 ms) instead of one ask() that blocks the event loop for seconds; heartbeats, reports
  // and commands are served in between.
  int max_new_candidates_per_tick = 32;
  // Candidates issued (written to DDS) per tick, over all studies, re-issues included. Each write costs
  // the event thread about a millisecond with 8 workers reading, and a tick that filled 128 fresh slots at
  // once held every sample that arrived meanwhile for 70-160 ms (tests/bench/proposal_throughput.sh, the
  // loop breakdown's "tick publish"); the rest of the slots are filled by the next ticks. At least 1.
  int max_issues_per_tick = 16;
  // A study's trial records stay on the (transient-local) trials topic while it is open and this long
  // after it ended, for clients following it live (`study run` collects them at the end); then they leave
  // the DDS writer, whose memory would otherwise grow with every trial ever run. The store keeps them.
  double finished_records_grace_s = 30.0;
  // The defaults a submitted study file's overrides are merged onto (empty paths: the shipped configs/).
  study::SpecDefaults spec_defaults;
  // Plant faults and divergences a trial may have before it is spent as a failure (never told as a cost).
  int max_fault_retries = 3;
  // A worker that refused a study's candidate gets none of that study's for this long (seconds), unless it
  // announces that it accepts again (an emergency stop released): a refusal costs a message, never a trial.
  double refusal_backoff_s = 2.0;
  // Every `now_s` handed to the coordinator is *monotonic* time (timeouts and leases must not fire, or
  // hang, when the wall clock is stepped); this clock gives the Unix time written to the store and shown
  // as a study's age. Empty: the system clock.
  std::function<double()> wall_clock_s;
  // Threads for model fits and acquisition optimisation (0: run them inline on the event thread, which
  // is deterministic to the call and what unit tests of the bookkeeping use).
  int model_threads = 0;
  // Threads one model job uses for its acquisition search (bo::BayesianOptimizer::set_threads) while fewer
  // studies have model jobs than there are model threads (one busy study on two cores: it uses both);
  // otherwise 1. Proposals do not depend on it.
  int acquisition_threads = 1;
  // Called from a model thread whenever a model job has finished: wake the event loop so it applies the
  // result at once instead of at its next timer tick. Must only signal.
  std::function<void()> on_model_result;
  // Called on the model thread at the start of every model job (tests hold a job with it).
  std::function<void(int study_id)> model_job_hook;
  // DDS-Security is on: a report or announcement counts only with the sender's authenticated identity
  // (the CN of its certificate) and a worker_id that identity owns (domain::worker_id_belongs_to). Without
  // security there is no identity to check and worker ids are taken as written.
  bool require_authenticated_workers = false;
};

using LogFn = std::function<void(const std::string&)>;

class Coordinator {
 public:
  Coordinator(study::StudyStore& store, Outbox& outbox, CoordinatorOptions options, LogFn log_info,
              LogFn log_warning);

  // Reloads every study from the store: observations replayed, in-flight candidates queued for
  // re-issue, trial records and states published again.
  void resume_from_store(double now_s);

  void handle_command(const domain::StudyCommand& command, double now_s);
  // `sender_identity`: the CN of the sending participant's certificate as DDS-Security authenticated it
  // (std::nullopt: unknown, or no security). Only looked at with require_authenticated_workers.
  void handle_report(const domain::RolloutReport& report, double now_s,
                     const std::optional<std::string>& sender_identity = std::nullopt);
  void handle_worker(const domain::WorkerAnnouncement& announcement, double now_s,
                     const std::optional<std::string>& sender_identity = std::nullopt);
  // `disposed_by`: for a dispose with DDS-Security, the disposing participant's CN ("" unknown); it must own
  // the worker id, or the dispose is refused (another identity cannot drop a worker). Nothing: no check
  // (no security, or the worker's writers are gone).
  void handle_worker_gone(std::uint64_t worker_key, double now_s,
                          const std::optional<std::string>& disposed_by = std::nullopt);
  // Applies finished model results, expires silent workers and overdue leases, fills free slots (starting
  // model jobs for the points still needed), publishes changed study states.
  void tick(double now_s);
  // Runs the event-thread half of every finished model job (tick() does it too); returns how many.
  int apply_model_results();
  // Blocks until no model job is running or queued (their results are applied by the next tick()).
  // For tests and an orderly shutdown.
  void wait_for_models() const { models_.wait_until_finished(); }
  int model_jobs_outstanding() const { return models_.outstanding(); }

  // A sample the transport could not turn into a domain value (dds::WireError): logged and counted with the
  // coordinator's own rejections.
  void reject_sample(const std::string& what, const std::string& why) { reject(what, why); }

  // Numbers for logs and tests.
  int live_workers() const { return pool_.size(); }
  int studies() const { return static_cast<int>(studies_.size()); }
  bool idle() const;  // no running study has work left
  // Points a study's model has proposed that wait for a free slot (0 for an unknown study).
  int points_waiting(int study_id) const;
  std::uint64_t rejected_samples() const { return rejected_; }
  std::uint64_t foreign_reports() const { return foreign_reports_; }  // for another store: ignored
  bool on_probation(const std::string& worker_id) const { return pool_.on_probation(worker_id); }

 private:
  struct InFlight {
    Eigen::VectorXd x;
    int attempt = 0;
    std::string worker_id;  // empty: waiting for a free slot
    double deadline_s = 0.0;
    // The worker each attempt was issued to: only that worker's report for that attempt counts, so a
    // participant that merely reads candidates cannot answer them.
    std::map<int, std::string> issued_to;
    bool validation = false;  // a validation set (hardware only, never told to the optimizer)
  };
  // What the event thread knows of a study's model, from its latest model job.
  struct ModelSnapshot {
    bool has_recommendation = false;
    int recommended_trial = 0;
    double recommended_predicted_cost = 0.0;
    std::map<std::string, double> recommended_params;
    Eigen::VectorXd recommended_x;  // the same point in the search space (the validation sets' centre)
  };
  struct Refusal {
    double until_s = 0.0;
    double backoff_s = 0.0;  // doubles with each identical refusal
    std::string why;
  };
  struct Study {
    int id = 0;
    std::string name;
    std::shared_ptr<const study::StudySpec> spec;  // what its rollouts compute
    study::StudyConfig config;                     // spec->config(), kept by value for the hot paths
    std::map<std::string, Refusal> refused_by;     // worker id -> its latest refusal of this study
    // Once the study is open, only its model jobs touch the optimizer (one at a time): the event thread
    // reads the model through `model` and never waits for it.
    std::shared_ptr<bo::BayesianOptimizer> optimizer;
    ModelSnapshot model;
    bool model_busy = false;                 // a model job of this study is queued or running
    int asking = 0;                          // points that job asks for
    std::vector<std::pair<int, bo::Observation>> untold;  // counted reports for the next job, in report order
    std::deque<Eigen::VectorXd> proposed;    // asked for, not yet stored and issued
    std::map<int, InFlight> in_flight;   // by trial id
    std::vector<int> told_trials;        // trial id of each optimizer observation, in the order told
    int next_trial_id = 0;
    int completed = 0, failed = 0, falls = 0, reissued = 0, consecutive_failures = 0;
    StudyStatus state = StudyStatus::kRunning;
    std::string message;
    double best_cost = std::nan("");
    int best_trial = 0;
    std::map<std::string, double> best_params;
    Eigen::VectorXd best_x;
    bool validation_started = false;   // its sets are in the store
    int validated = 0;                 // validation reports counted (not in `completed`)
    std::vector<int> validation_trials;  // counted validation trials, for retiring their records
    bool waiting_for_hardware = false;   // hardware work waits and no hardware worker is live
    std::string waiting_message;         // why work waits (published, never stored), "" when nothing waits
    double best_normalized_torque = std::nan(""), best_speed_mps = std::nan("");
    double created_at_s = 0.0, session_start_s = 0.0;
    int completed_at_session_start = 0;
    bool dirty = true;
    double records_leave_at_s = -1.0;  // monotonic time its trial records leave the topic (<0: not set)
    bool records_retired = false;      // they have (or, after a restart, were never published)
  };
  void reject(const std::string& what, const std::string& why);
  // With require_authenticated_workers: why `sender_identity` may not speak for `worker_id`, or nothing.
  std::optional<std::string> identity_refusal(const std::string& worker_id,
                                              const std::optional<std::string>& sender_identity) const;
  void submit(const domain::StudyCommand& command, double now_s, domain::CommandReply& reply);
  Study* find_study(int study_id);
  void open_study(Study&& study, const study::StoredStudy* stored, double now_s);
  void drop_worker(const std::string& worker_id, const std::string& why, double now_s);
  void unassign(Study& study, int trial_id, const std::string& why);
  struct FreeSlots {
    int simulation = 0;
    int hardware = 0;
  };
  static bool explores_on_hardware(const Study& s) {
    return s.config.explore_on == study::WorkerKindWanted::kHardware;
  }
  static int exploring_in_flight(const Study& s);
  // Lockstep studies (StudyConfig::lockstep): reported trials that continue the told prefix without a gap,
  // how many more trials may be proposed now, and the model job that tells and asks in trial order.
  static int lockstep_tellable(const Study& s);
  static int lockstep_room(const Study& s);
  void start_lockstep_model_job(Study& s, int ask);
  // What a model job hands back to the event thread: the fitted model's snapshot and saved state (if it
  // told anything), the points it asked for, or the error that stopped it.
  using FittedModel = std::optional<std::pair<ModelSnapshot, nlohmann::json>>;
  ModelPool::Completion model_job_result(int id, int ask, FittedModel fitted, std::vector<Eigen::VectorXd> points,
                                         std::string error);
  bool has_hardware_worker() const;
  // Stores the validation sets once the exploration is complete and told; true when it did.
  bool start_validation_if_due(Study& study);
  // A counted validation report: counters only (the optimizer never hears of it).
  void account_validation(Study& study, int trial_id, const domain::RolloutReport& report);
  // Failures, falls and the failure streak of one report, either phase; false when it did not run.
  bool count_outcome(Study& study, const domain::RolloutReport& report);
  // Says in the study's message whether its work waits, and for what (no hardware worker, a robot under an
  // emergency stop, workers that refused its spec).
  void note_hardware_wait(Study& study, double now_s);
  // True when this worker may be given this study's work now (not within a refusal's backoff).
  static bool may_serve(const Study& study, const PoolWorker& worker, double now_s);
  // A report that did not measure its trial (refused, plant_fault, diverged): re-issue it, or spend it as an
  // excluded failure once its faults reach the bound.
  void handle_unspent(Study& study, int trial_id, const domain::RolloutReport& report, double now_s);
  // Fails a running study whose last max_consecutive_failures reports were all failures.
  void fail_on_failure_streak(Study& study, const domain::RolloutReport& last);
  // A hardware worker may run the study only if it is the study's robot (StudyConfig::robot), when it names one.
  static bool is_study_robot(const Study& study, const PoolWorker& worker);
  // The study's spec as a DDS sample.
  static domain::SpecPublication spec_sample(const Study& study);
  // Resolves a study's spec (the service's defaults when options_.spec_defaults names none).
  study::SpecDefaults spec_defaults() const;
  // Running studies, rotated by one each tick so that no study is always served first.
  std::vector<Study*> round_robin_order();
  // Re-issues, then proposed points, to free slots of the right kind; returns the slots still free.
  FreeSlots issue_waiting_work(const std::vector<Study*>& order, double now_s);
  void issue_proposed(Study& study, std::vector<PoolWorker*>& slots, std::size_t& next_slot, int max_count, double now_s);
  // Starts a model job for each study with reports to tell or free slots to ask for (per-tick cap).
  void start_model_jobs(const std::vector<Study*>& order, FreeSlots free);
  void start_model_job(Study& study, int ask);
  // Sets how many threads the study's next job may use for its acquisition search (idle model threads).
  void use_idle_model_threads(Study& study);
  static ModelSnapshot snapshot_of(const bo::BayesianOptimizer& optimizer, const std::vector<int>& told_trials);
  // Frees the optimizer of a study whose records are retired once nothing can still reach it.
  static void release_optimizer_if_done(Study& study);
  void issue(Study& study, int trial_id, PoolWorker& worker, double now_s, bool reissue);
  // A new report: queued for the study's next model job (which tells it and saves the model state), then accounted.
  void count_report(Study& study, int trial_id, const Eigen::VectorXd& x, const domain::RolloutReport& report);
  // Counters and best of a report the optimizer already holds (a restart's replay).
  void account_report(Study& study, int trial_id, const Eigen::VectorXd& x, const domain::RolloutReport& report);
  // The study's optimizer from its stored observations: restored from the saved model state (one
  // factorisation), or replayed observation by observation when there is none.
  bo::BayesianOptimizer restored_optimizer(const Study& study, const study::StoredStudy* stored,
                                           const std::vector<bo::Observation>& observations) const;
  void finish_if_complete(Study& study);
  domain::Candidate make_candidate(const Study& study, int trial_id, const InFlight& f) const;
  domain::TrialRecord make_trial_record(const Study& study, int trial_id, const Eigen::VectorXd& x,
                                        const domain::RolloutReport& report) const;
  void publish_state(Study& study, double now_s);
  // A finished study, its grace period over: trial records off the topic, model dropped.
  void retire_finished(Study& study, double now_s);
  static bool is_open(const Study& s) { return domain::is_open(s.state); }

  study::StudyStore& store_;
  Outbox& out_;
  CoordinatorOptions options_;
  LogFn info_, warn_;
  double wall_now() const;  // Unix time, for the store
  std::map<int, Study> studies_;
  WorkerPool pool_;
  std::map<int, double> last_state_publish_;
  // Replies by (client_id, correlation_id): a client re-sends a command whose reply it did not get, and
  // gets the same reply again instead of a second execution (a second study, say). Last kMaxReplies.
  std::map<std::pair<std::string, std::uint64_t>, domain::CommandReply> replies_;
  std::deque<std::pair<std::string, std::uint64_t>> reply_order_;
  int round_robin_ = 0;
  int issues_left_this_tick_ = 0;  // max_issues_per_tick, counted down by every candidate a tick writes
  std::uint64_t rejected_ = 0;
  std::uint64_t foreign_reports_ = 0;
  std::set<std::uint64_t> foreign_stores_;  // store ids whose reports were ignored (logged once each)
  ModelPool models_;  // last member: destroyed first, so no job outlives what it refers to
};

}  // namespace cpgmatch::service
