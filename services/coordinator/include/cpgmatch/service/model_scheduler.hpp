// When each study's model is told its reports and asked for points, and on which thread. A study's model
// work runs as jobs on a ModelPool (one job per study at a time, different studies in parallel); what a job
// tells and asks is its study's strategy:
//
//  * AsynchronousModel: a job tells every report counted since the last one (one fit), then asks for the
//    free slots' worth of points with the points in flight as pending ("liar" batch). Fastest; proposals
//    depend on the order reports arrive in.
//  * LockstepModel (StudyConfig::lockstep = N): trial k is proposed from exactly trials 0..k-N-1, in trial
//    order, whatever order reports arrive in: the same study on any number of workers proposes the same
//    points. A job tells and asks one trial at a time.
//
// A study with one model over simulation and hardware (`hardware: {strategy: transfer | multi_fidelity}`) has
// a second kind of job, HardwareModelJob, for its bo::HardwareOptimizer: it tells that model the simulated
// results its optimizer was told since (in the same order) and the hardware reports counted since, then asks
// it for one hardware point when a robot of the study is free. The two kinds share the study's one-job-at-a-
// time turn; when both are due, the hardware job goes first (the robot is the scarce resource).
//
// The scheduler copies what a job needs out of the study before the job runs; the job's result comes back
// to the event thread through the completion the caller gives (the Coordinator stores the model state and
// queues the points). No store and no outbox here.
#pragma once

#include <functional>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "cpgmatch/service/model_pool.hpp"
#include "cpgmatch/service/study_run.hpp"

namespace cpgmatch::service {

// What a model job hands back to the event thread: the fitted model's snapshot and saved state (when it told
// anything), the points it asked for, or the error that stopped it.
struct ModelJobResult {
  int study_id = 0;
  int ask = 0;
  int epoch = 0;  // the study's proposal_epoch when the job was made (its points are dropped if it changed)
  // A lockstep job that asked: the optimizer's state at its last ask. The jobs after the exploration's last
  // ask tell every report beyond it; an extended study proposes on from this state (coordinator_replay.cpp)
  // instead of replaying its reports.
  std::optional<nlohmann::json> proposal_state;
  std::optional<std::pair<ModelSnapshot, nlohmann::json>> fitted;
  std::vector<Eigen::VectorXd> points;
  std::string error;
  // A HardwareModelJob's: its model's answer and saved state, and the hardware point it asked for.
  bool hardware = false;
  std::optional<std::pair<ModelSnapshot, nlohmann::json>> hardware_fitted;
  std::optional<bo::HardwareProposal> hardware_point;
};

// The work of one model job, run on a model thread.
using ModelWork = std::function<ModelJobResult()>;

class ModelStrategy {
 public:
  virtual ~ModelStrategy() = default;
  // How many of the `n` points the budget and free slots allow may be asked for now.
  virtual int allowed(const StudyRun& study, int n) const = 0;
  // Whether a job that asks for `ask` points is worth starting now (it may only tell).
  virtual bool worth_a_job(const StudyRun& study, int ask) const = 0;
  // Moves what the job tells out of the study (into told_trials) and returns its work; nothing when no job
  // can be made now (why goes to `why`). `hook` runs first on the model thread (tests hold a job with it).
  virtual std::optional<ModelWork> prepare(StudyRun& study, int ask, const std::function<void(int)>& hook,
                                           std::string& why) const = 0;
};

class AsynchronousModel final : public ModelStrategy {
 public:
  int allowed(const StudyRun&, int n) const override { return n; }
  bool worth_a_job(const StudyRun& study, int ask) const override { return ask > 0 || !study.untold.empty(); }
  std::optional<ModelWork> prepare(StudyRun& study, int ask, const std::function<void(int)>& hook,
                                   std::string& why) const override;
};

class LockstepModel final : public ModelStrategy {
 public:
  int allowed(const StudyRun& study, int n) const override { return std::min(n, room(study)); }
  bool worth_a_job(const StudyRun& study, int ask) const override;
  std::optional<ModelWork> prepare(StudyRun& study, int ask, const std::function<void(int)>& hook,
                                   std::string& why) const override;
  // Reported trials that continue the told prefix without a gap.
  static int tellable(const StudyRun& study);
  // How many more trials may be proposed now: trial k once trials 0..k-N-1 have reported.
  static int room(const StudyRun& study);
};

// The strategy a study's config asks for.
const ModelStrategy& strategy_for(const StudyRun& study);

// The jobs of a study's hardware model (StudyRun::hardware_optimizer).
class HardwareModelJob {
 public:
  enum class Kind { kAsk, kTell };
  // Whether a hardware job is due, given the free hardware slots that may serve the study:
  //  * kAsk: a robot of the study is free, hardware rollouts remain, at least start_after simulated results
  //    (two of them successful) are told, and no hardware point waits for a robot;
  //  * kTell: hardware reports wait to be told (the published answer follows them), or the study has
  //    nothing left to run and simulated results wait (the answer is final only with all of them).
  static std::optional<Kind> due(const StudyRun& study, int usable_hardware_slots);
  // Moves what the job tells out of the study and returns its work (tell both sources, ask with the
  // hardware points in flight as pending, then the answer and the state to save).
  static ModelWork prepare(StudyRun& study, Kind kind, const std::function<void(int)>& hook);
};

struct ModelSchedulerOptions {
  int threads = 0;               // model threads (0: jobs run inline, deterministic to the call)
  int acquisition_threads = 1;   // threads a lone job's acquisition search may use (CoordinatorOptions)
  int max_new_points_per_tick = 32;
  std::function<void()> on_result;            // from a model thread: wake the event loop
  std::function<void(int study_id)> job_hook; // on the model thread at the start of every job
};

class ModelScheduler {
 public:
  // `apply` runs on the event thread (in apply_results()) with each finished job's result.
  ModelScheduler(ModelSchedulerOptions options, std::function<void(ModelJobResult)> apply,
                 std::function<void(const std::string&)> warn);

  // Starts a model job for each study in `order` that has reports to tell or free slots to ask for: at most
  // max_new_points_per_tick points over all studies, and only for slots no running job or waiting point
  // will fill. `free_simulation` / `free_hardware`: free slots of each kind.
  // `hardware_slots_for`: the free hardware slots that may serve a study now (its robot, no refusal backoff).
  void start_jobs(std::map<int, StudyRun>& studies, const std::vector<StudyRun*>& order, int free_simulation,
                  int free_hardware, const std::function<int(const StudyRun&)>& hardware_slots_for);
  // Runs other work on the model threads (inline without threads), its completion on the event thread in
  // apply_results(). Jobs with the same key run one at a time; study jobs use the study id as key, so other
  // work takes keys no study has.
  void run_aside(std::uint64_t key, ModelPool::Work work) { pool_.submit(key, std::move(work)); }
  // Runs the event-thread half of every finished job; returns how many.
  int apply_results() { return pool_.run_finished(); }
  void wait_until_finished() const { pool_.wait_until_finished(); }
  int outstanding() const { return pool_.outstanding(); }

 private:
  void start_job(std::map<int, StudyRun>& studies, StudyRun& study, int ask);
  void submit(StudyRun& study, ModelWork work);
  ModelSchedulerOptions options_;
  std::function<void(ModelJobResult)> apply_;
  std::function<void(const std::string&)> warn_;
  ModelPool pool_;  // last: destroyed first, so no job outlives what it refers to
};

}  // namespace cpgmatch::service
