// One study as the optimizer service runs it: its spec and state, the trials in flight, the points its model
// proposed, its counters and its best. Bookkeeping only: no store, no outbox, no threads. The Coordinator
// decides when things happen and records them; a StudyRun says what they mean for the study (what a report
// counts as, whether the study is complete, what its state sample says, what a candidate of it carries).
#pragma once

#include <cmath>
#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "cpgmatch/bo/hardware_optimizer.hpp"
#include "cpgmatch/bo/optimizer.hpp"
#include "cpgmatch/domain/candidate.hpp"
#include "cpgmatch/domain/study_state.hpp"
#include "cpgmatch/domain/study_status.hpp"
#include "cpgmatch/service/worker_pool.hpp"
#include "cpgmatch/study/study_config.hpp"
#include "cpgmatch/study/study_spec.hpp"

namespace cpgmatch::service {

using domain::StudyStatus;

// A trial issued (or about to be) and not yet reported.
struct InFlight {
  Eigen::VectorXd x;
  int attempt = 0;
  std::string worker_id;  // empty: waiting for a free slot
  double deadline_s = 0.0;
  // The worker each attempt was issued to: only that worker's report for that attempt counts, so a
  // participant that merely reads candidates cannot answer them.
  std::map<int, std::string> issued_to;
  bool validation = false;  // a validation set (hardware only, never told to the optimizer)
  bool hardware = false;    // a hardware proposal (hardware only, told to the study's hardware model)
  bool enqueued = false;    // a queued known gait (exploration: told, counted); stored before any worker has it
  bool hardware_only() const { return validation || hardware; }
};

// What the event thread knows of a study's model, from its latest model job.
struct ModelSnapshot {
  bool has_recommendation = false;
  int recommended_trial = 0;
  double recommended_predicted_cost = 0.0;
  std::map<std::string, double> recommended_params;
  Eigen::VectorXd recommended_x;  // the same point in the search space (the validation sets' centre)

  static ModelSnapshot of(const bo::BayesianOptimizer& optimizer, const std::vector<int>& told_trials);
  // The hardware posterior's best hardware trial (fits the model when its observations changed).
  static ModelSnapshot of(bo::HardwareOptimizer& optimizer, const std::vector<int>& told_hardware_trials);
};

// The options of a study's hardware model (`hardware: {strategy: transfer | multi_fidelity}`): its strategy,
// fall limit, cost transform and seed.
bo::HardwareOptimizerOptions hardware_model_options(const study::StudyConfig& config);

// A worker's latest refusal of a study's candidates (a latched stop, a spec it cannot run).
struct Refusal {
  double until_s = 0.0;
  double backoff_s = 0.0;  // doubles with each identical refusal
  std::string why;
};

struct StudyRun {
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
  std::map<int, InFlight> in_flight;       // by trial id
  std::vector<int> told_trials;            // trial id of each optimizer observation, in the order told
  std::set<int> enqueued_trials;           // trials that are queued known gaits (`enqueue`), not proposals
  // Bumped when trials are enqueued: a model job started before brings points numbered for trial ids that
  // the queued gaits took, so its points are dropped (asking is pure: the next job proposes them again).
  int proposal_epoch = 0;
  bool reopening = false;                  // being extended: no model job may start (extend waits for the last)
  // Lockstep: the optimizer's state at its latest ask (ModelJobResult::proposal_state),
  // saved with every model state (key "proposal_state") so that an extension proposes on from it. Null: none.
  nlohmann::json proposal_state;
  int next_trial_id = 0;
  int completed = 0, failed = 0, falls = 0, reissued = 0, consecutive_failures = 0;
  StudyStatus state = StudyStatus::kRunning;
  std::string message;
  double best_cost = std::nan("");
  int best_trial = 0;
  std::map<std::string, double> best_params;
  Eigen::VectorXd best_x;
  bool validation_started = false;     // its sets are in the store
  int validated = 0;                   // validation reports counted (not in `completed`)
  std::vector<int> validation_trials;  // counted validation trials, for retiring their records
  // One model over both sources (config.hardware.models_hardware()): like `optimizer`, touched only by the
  // study's model jobs once it is open. Every simulated result the optimizer is told goes to it too, in the
  // same order; hardware reports go to it alone.
  std::shared_ptr<bo::HardwareOptimizer> hardware_optimizer;
  ModelSnapshot hardware_model;            // its answer: the hardware posterior's best hardware trial
  std::vector<std::pair<int, bo::Observation>> hardware_untold_sim;  // told to `optimizer`, not yet to it
  std::vector<std::pair<int, bo::Observation>> hardware_untold;      // hardware reports counted, not yet told
  std::vector<int> hardware_told_trials;   // trial id of each of its hardware observations, in the order told
  int simulation_successes = 0;            // successful simulated results told to `optimizer` (asks need 2)
  int hardware_done = 0;                   // hardware reports counted (not in `completed`)
  std::vector<int> hardware_trials;        // counted hardware trials, for retiring their records
  bool waiting_for_hardware = false;   // hardware work waits and no hardware worker is live
  std::string waiting_message;         // why work waits (published, never stored), "" when nothing waits
  double best_normalized_torque = std::nan(""), best_speed_mps = std::nan("");
  double created_at_s = 0.0, session_start_s = 0.0;
  int completed_at_session_start = 0;
  bool dirty = true;
  double records_leave_at_s = -1.0;  // monotonic time its trial records leave the topic (<0: not set)
  bool records_retired = false;      // they have (or, after a restart, were never published)

  bool is_open() const { return domain::is_open(state); }
  bool explores_on_hardware() const { return config.explore_on == study::WorkerKindWanted::kHardware; }
  int exploring_in_flight() const;
  bool models_hardware() const { return config.hardware.models_hardware(); }
  int hardware_in_flight() const;  // hardware proposals stored and not yet reported
  // Hardware rollouts of a transfer or multi_fidelity study still to propose.
  int hardware_to_propose() const;
  // Every exploration report counted and, with a validation phase, every set run; with a hardware model,
  // every hardware rollout counted and every result of both sources told to it (the answer is final).
  bool complete() const;

  // Failures, falls and the failure streak of one report, either phase; false when it did not run.
  bool count_outcome(const domain::RolloutReport& report);
  // Counters and best of an exploration report (the model is told it separately).
  void account_report(int trial_id, const Eigen::VectorXd& x, const domain::RolloutReport& report);
  // A counted validation report: counters only (the optimizer never hears of it).
  void account_validation(int trial_id, const domain::RolloutReport& report);
  // A counted hardware report of a transfer or multi_fidelity study: counters, and queued for the hardware
  // model (never the simulation's optimizer, never `best_*`, which stay the simulated best).
  void account_hardware(int trial_id, const Eigen::VectorXd& x, const domain::RolloutReport& report);
  // The observation the model learns from a report: its cost, a failure, a fall; excluded when spent on faults.
  static bo::Observation observation(const Eigen::VectorXd& x, const domain::RolloutReport& report);

  // A hardware worker may run the study only if it is the study's robot (StudyConfig::robot), when it names one.
  bool is_study_robot(const PoolWorker& worker) const;
  // True when this worker may be given this study's work now (its robot, and not within a refusal's backoff).
  bool may_serve(const PoolWorker& worker, double now_s) const;

  domain::Candidate candidate(std::uint64_t store_id, int trial_id) const;
  domain::TrialRecord trial_record(int trial_id, const Eigen::VectorXd& x, const domain::RolloutReport& report) const;
  domain::SpecPublication spec_publication() const;
  // The state sample: `workers` live on the domain, `wall_now_s` Unix time, `now_s` monotonic time.
  domain::StudyState state_sample(int workers, double wall_now_s, double now_s) const;
};

}  // namespace cpgmatch::service
