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
//    default), validation sets and hardware proposals to hardware workers only. The validation phase (a study with a
//    `validation` key) starts once the exploration budget is reported and the model holds every report:
//    its N sets are stored at once (phase "validation"), so a restart issues the same sets. Validation
//    reports are never told to the optimizer: they measure the answer on hardware, they do not steer it.
//    No hardware worker on the domain: the study waits and says so in its state's message.
//  * one model over both sources (`hardware: {strategy: transfer | multi_fidelity}`): every simulated result
//    is also told to the study's bo::HardwareOptimizer, which proposes one hardware rollout per free robot
//    slot (phase "hardware", stored at once) once start_after simulated results are in, until the hardware
//    budget is spent; hardware reports go to that model only. The study's answer is its hardware posterior's
//    best hardware trial; the study is done when both budgets are spent and every result is told.
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
#include "cpgmatch/service/dispatcher.hpp"
#include "cpgmatch/service/model_scheduler.hpp"
#include "cpgmatch/service/outbox.hpp"
#include "cpgmatch/service/reply_cache.hpp"
#include "cpgmatch/service/study_run.hpp"
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
  // Where the service's workers would be, for the message of a study that waits for a kind of worker none
  // of which is there ("waiting for simulation workers: none on domain 7").
  std::string where = "this domain";
  // Resolve a submitted study file's spec (YAML, defaults, canonical JSON, SHA-256: about 7 ms) on a model
  // thread instead of the event thread, and answer the submit once it is resolved. A burst of 20 submits
  // held the event loop for 136-221 ms resolving them (docs/dds.md). Off: resolved at once on the event
  // thread (unit tests' determinism: the reply is out when handle_command returns).
  bool resolve_specs_off_thread = false;
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

// How a worker's announcement ended (Coordinator::handle_worker_gone).
enum class WorkerExit {
  kLeft,  // it disposed its announcement on the way out: a clean shutdown
  kLost,  // no writer of it is alive any more, and it said nothing
};

// A submitted study's spec, resolved (possibly on a model thread), or why it could not be.
struct ResolvedSubmission {
  std::shared_ptr<const study::StudySpec> spec;
  std::string error;
};

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
  // A worker's announcement instance ended: `exit` says whether it left (it disposed its announcement: a
  // clean shutdown) or was lost (its writers vanished without a word: a crash, kill -9 or a cut link), so
  // the log says which. `disposed_by`: for a dispose with DDS-Security, the disposing participant's CN (""
  // unknown); it must own the worker id, or the dispose is refused (another identity cannot drop a
  // worker). Nothing: no check (no security, or the worker's writers are gone).
  void handle_worker_gone(std::uint64_t worker_key, double now_s, WorkerExit exit,
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
  void reject(const std::string& what, const std::string& why);
  // With require_authenticated_workers: why `sender_identity` may not speak for `worker_id`, or nothing.
  std::optional<std::string> identity_refusal(const std::string& worker_id,
                                              const std::optional<std::string>& sender_identity) const;
  // Runs a command and answers it: the reply is cached (a re-sent command gets it again) and published;
  // a store that cannot record the command's effect answers and rethrows.
  void answer(const domain::StudyCommand& command, const std::function<void(domain::CommandReply&)>& execute);
  // Why a submitted study file is refused before any parsing (too large), or nothing.
  std::optional<std::string> oversized(const domain::StudyCommand& command) const;
  // Stores and opens a submitted study whose spec resolved, or answers why it did not.
  void accept_submission(const domain::StudyCommand& command, const ResolvedSubmission& resolved, double now_s,
                         domain::CommandReply& reply);
  // CoordinatorOptions::resolve_specs_off_thread: resolves on a model thread, accepts on the event thread.
  void resolve_off_thread(const domain::StudyCommand& command);
  StudyRun* find_study(int study_id);
  void open_study(StudyRun&& study, const study::StoredStudy* stored, double now_s);
  void drop_worker(const std::string& worker_id, const std::string& why, double now_s);
  void unassign(StudyRun& study, int trial_id, const std::string& why);
  bool has_hardware_worker() const;
  // Stores the validation sets once the exploration is complete and told; true when it did.
  bool start_validation_if_due(StudyRun& study);
  // Says in the study's message whether its work waits, and for what (no hardware worker, a robot under an
  // emergency stop, workers that refused its spec).
  void note_hardware_wait(StudyRun& study, double now_s);
  // A report that did not measure its trial (refused, plant_fault, diverged): re-issue it, or spend it as an
  // excluded failure once its faults reach the bound.
  void handle_unspent(StudyRun& study, int trial_id, const domain::RolloutReport& report, double now_s);
  // Fails a running study whose last max_consecutive_failures reports were all failures.
  void fail_on_failure_streak(StudyRun& study, const domain::RolloutReport& last);
  // Resolves a study's spec (the service's defaults when options_.spec_defaults names none).
  study::SpecDefaults spec_defaults() const;
  // Running studies, rotated by one each tick so that no study is always served first.
  std::vector<StudyRun*> round_robin_order();
  // Frees the optimizer of a study whose records are retired once nothing can still reach it.
  static void release_optimizer_if_done(StudyRun& study);
  // A new report: queued for the study's next model job (which tells it and saves the model state), then accounted.
  void count_report(StudyRun& study, int trial_id, const Eigen::VectorXd& x, const domain::RolloutReport& report);
  // A spent trial's report, by its kind: exploration (count_report), validation set, or hardware proposal.
  void account(StudyRun& study, int trial_id, const InFlight& spent, const domain::RolloutReport& report);
  // Hardware proposals of a transfer or multi_fidelity study are due (rollouts left, the simulation far enough).
  static bool hardware_proposals_due(const StudyRun& study);
  // A hardware model job's result, on the event thread: its state stored, its point stored as a hardware trial.
  void apply_hardware_result(StudyRun& study, ModelJobResult result);
  // The study's optimizer from its stored observations: restored from the saved model state (one
  // factorisation), or replayed observation by observation when there is none.
  // `state`: the saved state at observations.size(), when the store has one (nothing: replay them all).
  bo::BayesianOptimizer restored_optimizer(const StudyRun& study, const study::StoredStudy* stored,
                                           const std::optional<bo::ModelState>& state,
                                           const std::vector<bo::Observation>& observations) const;
  // A transfer or multi_fidelity study's hardware model from the optimizer's simulated observations (in the
  // order told) and its stored hardware reports (in the order counted), with its saved state.
  void restore_hardware_model(StudyRun& study, const study::StoredStudy* stored,
                              const std::vector<bo::Observation>& simulated,
                              const std::vector<const study::StoredTrial*>& hardware);
  void finish_if_complete(StudyRun& study);
  void publish_state(StudyRun& study, double now_s);
  // A finished study, its grace period over: trial records off the topic, model dropped.
  void retire_finished(StudyRun& study, double now_s);
  // A finished model job's result, on the event thread: its model state stored, its points queued.
  void apply_model_result(ModelJobResult result);

  // Steering a study as Optuna users can (coordinator_steering.cpp, docs/steering.md).
  // `study extend`: a stopped or finished study continues with more trials, reopened from the store exactly
  // as a restart reopens it. Answered at once, or when the study's running model job has finished.
  void extend_study(const domain::StudyCommand& command, double now_s);
  std::optional<std::string> extend_refusal(const domain::StudyCommand& command);  // why not, or nothing
  void extend_now(const domain::StudyCommand& command, double now_s, domain::CommandReply& reply);
  // `study enqueue`: known gaits as the study's next trials.
  void enqueue_command(const domain::StudyCommand& command, domain::CommandReply& reply);
  // Why `gaits` cannot be queued in a study of `spec` with room for `room` more trials, or nothing (their
  // points then in `points`).
  static std::optional<std::string> enqueue_refusal(const study::StudySpec& spec,
                                                    const std::vector<domain::EnqueuedGait>& gaits, int room,
                                                    std::vector<Eigen::VectorXd>& points);
  // Stores the points as the study's next trials (phase enqueued, no worker yet); returns their trial ids.
  std::vector<int> enqueue_points(StudyRun& study, const std::vector<Eigen::VectorXd>& points,
                                  const std::vector<domain::EnqueuedGait>& gaits);

  study::StudyStore& store_;
  Outbox& out_;
  CoordinatorOptions options_;
  LogFn info_, warn_;
  double wall_now() const;  // Unix time, for the store
  std::map<int, StudyRun> studies_;
  WorkerPool pool_;
  Dispatcher dispatcher_;  // after pool_: it refers to it
  std::map<int, double> last_state_publish_;
  std::set<std::pair<std::string, std::uint64_t>> resolving_;  // submits whose spec a model thread resolves
  std::uint64_t next_submit_job_ = 0;
  double now_s_ = 0.0;  // monotonic time of the latest event or tick (for work finished off the event thread)
  ReplyCache replies_;  // a re-sent command is answered again, not executed again
  int round_robin_ = 0;
  std::uint64_t rejected_ = 0;
  std::uint64_t foreign_reports_ = 0;
  std::set<std::uint64_t> foreign_stores_;  // store ids whose reports were ignored (logged once each)
  ModelScheduler models_;  // last member: destroyed first, so no job outlives what it refers to
};

}  // namespace cpgmatch::service
