// Steering a study as Optuna users can (issue 24): `study extend` continues a stopped or finished study with
// its model, exactly (extending then running proposes what one study with the larger budget from the start
// proposed, restarts of the optimizer in between included); `enqueue` runs known gaits as the next trials.
// A Coordinator driven by hand, model jobs inline, one candidate answered at a time.
#include <gtest/gtest.h>

#include <functional>
#include <atomic>
#include <future>
#include <map>

#include <fmt/format.h>

#include "coordinator_test_support.hpp"
#include "cpgmatch/params.hpp"
#include "cpgmatch/rollout.hpp"
#include "cpgmatch/study/study_spec.hpp"

namespace cpgmatch::service {
namespace {

using test_support::CoordinatorFixture;
using Points = std::map<int, std::map<std::string, double>>;

// A smooth cost of a gait: the model has something to learn, and the same gait always costs the same.
double cost_of(const std::map<std::string, double>& parameters) {
  double cost = 0.5;
  for (const auto& [name, value] : parameters) cost += (value - 0.3) * (value - 0.3);
  return cost;
}

// The shipped base parameters (configs/params/default.yaml) with some searched values changed: a gait file.
domain::EnqueuedGait gait(const std::string& source, const std::map<std::string, double>& changes) {
  domain::EnqueuedGait g;
  g.source = source;
  g.parameters = to_map(load_parameters(study::SpecDefaults::shipped().base_parameters_path));
  for (const auto& [name, value] : changes) g.parameters[name] = value;
  return g;
}

class SteeringTest : public CoordinatorFixture {
 public:
  SteeringTest() : CoordinatorFixture("steering") {}

 protected:
  CoordinatorOptions options() override {
    CoordinatorOptions o = CoordinatorFixture::options();
    o.model_threads = model_threads_;
    o.model_job_hook = [this](int) {
      if (hold_) held_.wait();
    };
    return o;
  }
  // A new store and coordinator: a second, independent study history in the same test.
  void fresh() {
    coordinator_.reset();
    store_.reset();
    test_support::remove_store(path_);
    open();
    issued_.clear();
    outstanding_.clear();
    seen_ = 0;
  }
  void join_workers() {
    for (int i = 0; i < workers_; ++i) worker("w" + std::to_string(i), 1, domain::WorkerKind::kSimulation);
  }
  // kill -9 and restart on the same store: candidates in flight go out again.
  void restart() {
    open();
    coordinator_->resume_from_store(now_);
    join_workers();
    seen_ = 0;
    outstanding_.clear();
    coordinator_->tick(now_ += 0.01);
  }
  void collect() {
    for (; seen_ < out_.candidates.size(); ++seen_) {
      const domain::Candidate& c = out_.candidates[seen_];
      issued_[c.id.trial_id] = c.parameters;
      outstanding_[c.id.trial_id] = c;
    }
  }
  // Answers the outstanding candidates one at a time (oldest or newest first) until none is left; `hook(n)`
  // runs before the n-th answer (it may restart, enqueue, stop).
  void drive(const std::function<void(int)>& hook = {}) {
    for (int n = 0; n < 400; ++n) {
      collect();
      if (hook) {
        hook(n);
        collect();
      }
      if (outstanding_.empty()) return;
      const auto pick = newest_first_ ? std::prev(outstanding_.end()) : outstanding_.begin();
      coordinator_->handle_report(
          test_support::completed_report(pick->second, cost_of(pick->second.parameters), domain::WorkerKind::kSimulation),
          now_);
      outstanding_.erase(pick);
      coordinator_->tick(now_ += 0.01);
    }
    ADD_FAILURE() << "the study did not finish in 400 answers";
  }
  int start(const std::string& yaml, const std::vector<domain::EnqueuedGait>& enqueue = {}) {
    domain::StudyCommand c = test_support::submit_command(yaml, ++correlation_);
    c.enqueue = enqueue;
    coordinator_->handle_command(c, now_);
    EXPECT_TRUE(out_.replies.back().ok) << out_.replies.back().message;
    join_workers();
    coordinator_->tick(now_ += 0.01);
    return out_.replies.back().study_id;
  }
  domain::CommandReply command(domain::CommandKind kind, int study_id, int added = 0,
                               const std::vector<domain::EnqueuedGait>& gaits = {}) {
    domain::StudyCommand c;
    c.correlation_id = ++correlation_;
    c.client_id = "test";
    c.kind = kind;
    c.study_id = study_id;
    c.added_trials = added;
    c.enqueue = gaits;
    coordinator_->handle_command(c, now_);
    return out_.replies.back();
  }
  static std::string study_yaml(int budget, int lockstep, int initial_points = 4) {
    return "name: s\nbudget: " + std::to_string(budget) + "\ninitial_points: " + std::to_string(initial_points) +
           "\nseed: 3\nlockstep: " + std::to_string(lockstep) + "\nrollout: {entrain_s: 1, eval_s: 1}\n";
  }
  // A study of `total` trials from the start, and one of `first` extended by total - first once done, with
  // restarts of the optimizer where asked; both must have issued the same gait for every trial.
  void expect_extension_is_exact(int first, int total, int lockstep, bool restart_before_extend,
                                 bool restart_after_extend, int initial_points = 4) {
    fresh();
    const int straight_id = start(study_yaml(total, lockstep, initial_points));
    drive();
    const Points straight = issued_;
    ASSERT_EQ(straight.size(), static_cast<std::size_t>(total));
    EXPECT_EQ(store_->load(straight_id)->state, "done");
    const std::string straight_spec = store_->load(straight_id)->spec.sha256;

    fresh();
    const int id = start(study_yaml(first, lockstep, initial_points));
    drive();
    ASSERT_EQ(store_->load(id)->state, "done");
    ASSERT_EQ(issued_.size(), static_cast<std::size_t>(first));
    if (lockstep > 0) {
      // The jobs after the last ask told every report; the state at that ask (trial first-1 proposed from
      // trials 0..first-N-2) is saved with the final one, and the extension proposes on from it (one more
      // tell) instead of replaying every report.
      const nlohmann::json saved = store_->load(id)->model_state;
      ASSERT_TRUE(saved.contains("proposal_state")) << saved.dump();
      EXPECT_EQ(saved["proposal_state"]["observations"].get<int>(), first - lockstep - 1);
      EXPECT_EQ(saved["observations"].get<int>(), first);
    }
    if (restart_before_extend) restart();
    const domain::CommandReply reply = command(domain::CommandKind::kExtend, id, total - first);
    ASSERT_TRUE(reply.ok) << reply.message;
    EXPECT_NE(reply.message.find(fmt::format("budget {} -> {}", first, total)), std::string::npos) << reply.message;
    if (restart_after_extend) restart();
    coordinator_->tick(now_ += 0.01);
    drive();
    const std::string what = fmt::format("lockstep {}, restarts {}/{}", lockstep, restart_before_extend, restart_after_extend);
    ASSERT_EQ(issued_.size(), straight.size()) << what;
    for (const auto& [trial, point] : straight) EXPECT_EQ(point, issued_.at(trial)) << "trial " << trial << ", " << what;
    const auto stored = store_->load(id);
    EXPECT_EQ(stored->state, "done") << what;
    EXPECT_EQ(out_.states.back().completed, total);
    EXPECT_EQ(out_.states.back().budget, total);
    // Its spec is now the larger budget's: the same hash as the study submitted with it from the start.
    EXPECT_EQ(stored->spec.sha256, straight_spec);
    EXPECT_EQ(study::StudySpec::from_json_text(stored->spec.json, "s").config().budget, total);
    EXPECT_NE(stored->spec.origin.find("extended: budget"), std::string::npos) << stored->spec.origin;
  }

  int workers_ = 1;
  bool newest_first_ = false;
  int model_threads_ = 0;          // 0: model jobs inline
  std::atomic<bool> hold_{false};  // with model threads: jobs wait for held_ while set
  std::shared_future<void> held_;
  Points issued_;
  std::map<int, domain::Candidate> outstanding_;
  std::size_t seen_ = 0;
};

TEST_F(SteeringTest, AnExtendedStudyProposesWhatTheLargerBudgetProposedFromTheStartOneWorker) {
  // One worker, asynchronous: each report is told (and fitted) before the next proposal, so the run is a
  // function of its seed, and the larger budget's run fits the report that the smaller one's last job left
  // unfitted. Extended right after the initial design (never fitted) and with the model in use.
  expect_extension_is_exact(3, 10, 0, false, false, 3);
  expect_extension_is_exact(7, 12, 0, false, false);
  expect_extension_is_exact(7, 12, 0, true, true);
}

TEST_F(SteeringTest, AnExtendedLockstepStudyIsTheLargerBudgetsStudyWhateverTheOrderAndRestarts) {
  // Lockstep 2 on two workers, answered newest first: the finished study's last job told every report,
  // more than the next proposal of the larger budget's run had seen; the reopened optimizer is replayed
  // to exactly what it had seen.
  workers_ = 2;
  newest_first_ = true;
  expect_extension_is_exact(8, 14, 2, false, false);
  expect_extension_is_exact(8, 14, 2, true, false);
  expect_extension_is_exact(8, 14, 2, false, true);
}

TEST_F(SteeringTest, AStoppedStudyIsExtendedWithItsTrialsInFlightKeptByTheirWorkers) {
  workers_ = 2;
  const int id = start(study_yaml(12, 0));
  drive([&](int n) {
    if (n == 5) {
      EXPECT_TRUE(command(domain::CommandKind::kStop, id).ok);
    }
  });
  // Stopped after 5 reports; the candidate in flight then was still reported and counted.
  const auto stopped = store_->load(id);
  ASSERT_EQ(stopped->state, "stopped");
  int done = 0;
  for (const auto& t : stopped->trials) done += t.status == study::TrialStatus::kDone;
  EXPECT_EQ(done, 7);
  EXPECT_EQ(command(domain::CommandKind::kStop, id).message, fmt::format("study {} is stopped: nothing to do", id));
  const domain::CommandReply reply = command(domain::CommandKind::kExtend, id, 3);
  ASSERT_TRUE(reply.ok) << reply.message;
  coordinator_->tick(now_ += 0.01);
  drive();
  EXPECT_EQ(store_->load(id)->state, "done");
  EXPECT_EQ(out_.states.back().completed, 15);  // 12 + 3
  EXPECT_EQ(issued_.size(), 15u);
}

TEST_F(SteeringTest, AnExtendSentWhileTheStudysModelJobRunsIsAnsweredOnceWhenTheJobHasFinished) {
  // As in the service: model jobs on their own thread. The study's first job is held (a slow fit); an extend
  // then cannot reopen the study under it: it waits for the job, and a re-sent command gets the one reply.
  model_threads_ = 1;
  std::promise<void> release;
  held_ = release.get_future().share();
  hold_ = true;
  open();
  const int id = start(study_yaml(6, 0));
  ASSERT_EQ(coordinator_->model_jobs_outstanding(), 1);
  ASSERT_TRUE(command(domain::CommandKind::kStop, id).ok);
  const std::size_t replies = out_.replies.size();
  domain::StudyCommand extend;
  extend.correlation_id = 4242;
  extend.client_id = "test";
  extend.kind = domain::CommandKind::kExtend;
  extend.study_id = id;
  extend.added_trials = 3;
  coordinator_->handle_command(extend, now_);
  coordinator_->handle_command(extend, now_);  // re-sent: no reply arrived yet
  coordinator_->tick(now_ += 0.01);
  EXPECT_EQ(out_.replies.size(), replies);  // nothing answered while the job holds the model
  hold_ = false;
  release.set_value();
  for (int i = 0; i < 10 && out_.replies.size() == replies; ++i) {
    coordinator_->wait_for_models();
    coordinator_->tick(now_ += 0.01);
  }
  ASSERT_EQ(out_.replies.size(), replies + 1);
  EXPECT_TRUE(out_.replies.back().ok) << out_.replies.back().message;
  EXPECT_NE(out_.replies.back().message.find("budget 6 -> 9"), std::string::npos) << out_.replies.back().message;
  EXPECT_EQ(store_->load(id)->state, "running");
  // It runs its nine trials to the end (each answered, then the model jobs it starts waited for).
  for (int round = 0; round < 100 && store_->load(id)->state != "done"; ++round) {
    collect();
    for (auto& [trial, c] : outstanding_) {
      coordinator_->handle_report(test_support::completed_report(c, cost_of(c.parameters), domain::WorkerKind::kSimulation), now_);
    }
    outstanding_.clear();
    coordinator_->tick(now_ += 0.01);
    coordinator_->wait_for_models();
    coordinator_->tick(now_ += 0.01);
  }
  EXPECT_EQ(store_->load(id)->state, "done");
  EXPECT_EQ(issued_.size(), 9u);
}

TEST_F(SteeringTest, ExtendRefusesWhatItCannotContinue) {
  const int id = start(study_yaml(4, 0));
  EXPECT_EQ(command(domain::CommandKind::kExtend, 99, 5).message, "no study 99");
  const domain::CommandReply zero = command(domain::CommandKind::kExtend, id, 0);
  EXPECT_FALSE(zero.ok);
  EXPECT_NE(zero.message.find("must be > 0"), std::string::npos) << zero.message;
  EXPECT_FALSE(command(domain::CommandKind::kExtend, id, -3).ok);
  EXPECT_NE(command(domain::CommandKind::kExtend, id, 200'000).message.find("more than a study may have"),
            std::string::npos);
  drive();
  store_->set_state(id, "failed", "10 rollouts in a row could not run");
  restart();
  const domain::CommandReply failed = command(domain::CommandKind::kExtend, id, 5);
  EXPECT_FALSE(failed.ok);
  EXPECT_NE(failed.message.find("failed"), std::string::npos) << failed.message;
  // A validation phase follows the whole exploration: not continued.
  const int validated = start("name: v\nbudget: 3\ninitial_points: 3\nvalidation: {hardware_sets: 2}\n");
  EXPECT_NE(command(domain::CommandKind::kExtend, validated, 2).message.find("hardware phase"), std::string::npos);
}

TEST_F(SteeringTest, EnqueuedGaitsAtSubmitRunFirstCountInTheBudgetAndTheModelLearnsThem) {
  const domain::EnqueuedGait good = gait("good.yaml", {{"hip_amplitude", 0.31}, {"overswing", 0.22}});
  const domain::EnqueuedGait other = gait("other.yaml", {{"hip_offset", 0.05}});
  const int id = start(study_yaml(6, 0), {good, other});
  drive();
  ASSERT_EQ(issued_.size(), 6u);
  EXPECT_EQ(issued_.at(0), good.parameters);
  EXPECT_EQ(issued_.at(1), other.parameters);
  const auto stored = store_->load(id);
  EXPECT_EQ(stored->state, "done");
  EXPECT_EQ(stored->trials[0].phase, "enqueued");
  EXPECT_EQ(stored->trials[1].phase, "enqueued");
  EXPECT_EQ(stored->trials[2].phase, "exploration");
  // Told to the model like every trial: its saved state holds all six observations.
  EXPECT_EQ(stored->model_state.at("observations").get<int>(), 6);
  int enqueued_records = 0;
  for (const auto& t : out_.trials) enqueued_records += t.enqueued;
  EXPECT_EQ(enqueued_records, 2);
  for (const auto& t : out_.trials) EXPECT_EQ(t.enqueued, t.trial_id < 2) << "trial " << t.trial_id;
}

TEST_F(SteeringTest, AGaitEnqueuedMidStudyIsTheNextTrialAndSurvivesARestart) {
  const domain::EnqueuedGait known = gait("known.yaml", {{"duty_factor_front", 0.61}});
  int id = 0;
  auto run = [&](bool restart_after_enqueue) {
    fresh();
    id = start(study_yaml(10, 0));
    drive([&](int n) {
      if (n != 6) return;
      const domain::CommandReply reply = command(domain::CommandKind::kEnqueue, id, 0, {known});
      ASSERT_TRUE(reply.ok) << reply.message;
      EXPECT_NE(reply.message.find("queued as trial 7 (known.yaml)"), std::string::npos) << reply.message;
      if (restart_after_enqueue) restart();
    });
    return issued_;
  };
  const Points straight = run(false);
  // The one worker was busy with trial 6 when the gait was queued: it became trial 7, the next one issued.
  ASSERT_EQ(straight.size(), 10u);
  EXPECT_EQ(straight.at(7), known.parameters);
  const auto stored = store_->load(id);
  EXPECT_EQ(stored->trials[7].phase, "enqueued");
  EXPECT_EQ(out_.states.back().completed, 10);  // it counted in the budget of 10
  // Killed right after the enqueue (the gait stored, issued to nobody yet): the same study.
  const Points restarted = run(true);
  ASSERT_EQ(restarted.size(), straight.size());
  for (const auto& [trial, point] : straight) EXPECT_EQ(point, restarted.at(trial)) << "trial " << trial;
}

TEST_F(SteeringTest, EnqueueRefusesGaitsTheStudyCouldNotHaveProposed) {
  const int id = start(study_yaml(5, 0) + "constraints: [\"hip_offset + hip_amplitude * (1 + overswing) <= 0.5\"]\n");
  const domain::CommandReply outside =
      command(domain::CommandKind::kEnqueue, id, 0, {gait("wide.yaml", {{"hip_offset", 0.2}, {"hip_amplitude", 0.3}})});
  EXPECT_FALSE(outside.ok);
  EXPECT_NE(outside.message.find("wide.yaml: violates the study's constraint \"hip_offset + hip_amplitude * (1 + "
                                 "overswing) <= 0.5\""),
            std::string::npos)
      << outside.message;
  domain::EnqueuedGait missing = gait("short.yaml", {});
  missing.parameters.erase("overswing");
  EXPECT_NE(command(domain::CommandKind::kEnqueue, id, 0, {missing}).message.find("short.yaml: no value for 'overswing'"),
            std::string::npos);
  // frequency is fixed at 1 Hz in the study: a gait at 1.2 Hz is not one of its trials.
  EXPECT_NE(command(domain::CommandKind::kEnqueue, id, 0, {gait("fast.yaml", {{"frequency", 1.2}})})
                .message.find("frequency = 1.2 is not the study's value 1"),
            std::string::npos);
  EXPECT_NE(command(domain::CommandKind::kEnqueue, id, 0, {gait("far.yaml", {{"hip_offset", 0.9}})})
                .message.find("outside the study's search space"),
            std::string::npos);
  EXPECT_EQ(command(domain::CommandKind::kEnqueue, 42, 0, {gait("a.yaml", {})}).message, "no study 42");
  // Room: 5 in the budget, one in flight on the worker.
  const std::vector<domain::EnqueuedGait> five(5, gait("a.yaml", {}));
  EXPECT_NE(command(domain::CommandKind::kEnqueue, id, 0, five).message.find("room for 4 more trials"), std::string::npos);
  // At submit too: nothing is stored when a gait is refused.
  domain::StudyCommand submit = test_support::submit_command(study_yaml(4, 0), ++correlation_);
  submit.enqueue = {gait("ok.yaml", {}), gait("bad.yaml", {{"overswing", 0.9}})};
  coordinator_->handle_command(submit, now_);
  EXPECT_FALSE(out_.replies.back().ok);
  EXPECT_NE(out_.replies.back().message.find("bad.yaml"), std::string::npos) << out_.replies.back().message;
  EXPECT_EQ(store_->load_all().size(), 1u);
  drive();
  EXPECT_NE(command(domain::CommandKind::kEnqueue, id, 0, {gait("late.yaml", {})}).message.find("extend it first"),
            std::string::npos);
}

}  // namespace
}  // namespace cpgmatch::service
