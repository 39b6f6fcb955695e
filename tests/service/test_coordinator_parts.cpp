// The coordinator's parts on their own (services/coordinator): a study run's bookkeeping, the lockstep model
// strategy's arithmetic, the dispatcher's per-tick cap and slot kinds, the reply cache. The Coordinator's
// own tests (test_coordinator.cpp) check them working together.
#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>

#include "cpgmatch/service/dispatcher.hpp"
#include "cpgmatch/service/model_scheduler.hpp"
#include "cpgmatch/service/reply_cache.hpp"
#include "cpgmatch/service/study_run.hpp"

namespace cpgmatch::service {
namespace {

std::shared_ptr<const study::StudySpec> spec_of(const std::string& yaml) {
  return std::make_shared<const study::StudySpec>(
      study::StudySpec::resolve(yaml, "parts.yaml", study::SpecDefaults::shipped()));
}

StudyRun run_of(const std::string& yaml) {
  StudyRun s;
  s.id = 1;
  s.spec = spec_of(yaml);
  s.config = s.spec->config();
  return s;
}

domain::RolloutReport measured(double cost, domain::Outcome outcome = domain::Outcome::kCompleted) {
  domain::RolloutReport r;
  r.worker_id = "w";
  r.outcome = outcome;
  r.summary.cost = cost;
  r.summary.normalized_torque = 10.0 * cost;
  r.summary.mean_speed_mps = 0.3;
  return r;
}

TEST(StudyRun, CountsFallsFailuresAndTheBestAndSaysWhatTheModelLearns) {
  StudyRun s = run_of("name: p\nbudget: 3\ninitial_points: 2\n");
  const Eigen::VectorXd x = Eigen::VectorXd::Constant(s.config.space.size(), 0.5);
  s.account_report(0, x, measured(3.0));
  s.account_report(1, x, measured(17.0, domain::Outcome::kFell));
  domain::RolloutReport fault = measured(std::nan(""), domain::Outcome::kPlantFault);
  s.account_report(2, x, fault);
  EXPECT_EQ(s.completed, 3);
  EXPECT_EQ(s.falls, 1);
  EXPECT_EQ(s.failed, 1);
  EXPECT_EQ(s.consecutive_failures, 1);
  EXPECT_EQ(s.best_trial, 0);  // the fall's 17 is not better than 3
  EXPECT_DOUBLE_EQ(s.best_cost, 3.0);
  EXPECT_DOUBLE_EQ(s.best_normalized_torque, 30.0);
  EXPECT_TRUE(s.complete());
  // The model learns a fall as a fall, and a fault spent after its retries never as a cost.
  const bo::Observation fell = StudyRun::observation(x, measured(17.0, domain::Outcome::kFell));
  EXPECT_TRUE(fell.fell);
  EXPECT_FALSE(fell.failed);
  const bo::Observation spent = StudyRun::observation(x, fault);
  EXPECT_TRUE(spent.failed);
  EXPECT_TRUE(spent.excluded);
  EXPECT_FALSE(StudyRun::observation(x, measured(0.0, domain::Outcome::kError)).excluded);
}

TEST(StudyRun, ACandidateCarriesTheSpecTheTrialSeedAndTheFullParameterSet) {
  StudyRun s = run_of("name: p\nbudget: 3\ninitial_points: 2\nseed: 7\n");
  s.in_flight[4] = InFlight{Eigen::VectorXd::Constant(s.config.space.size(), 0.5), 2, "w", 0.0, {}};
  const domain::Candidate c = s.candidate(99, 4);
  EXPECT_EQ(c.id.store_id, 99u);
  EXPECT_EQ(c.id.trial_id, 4);
  EXPECT_EQ(c.id.attempt, 2);
  EXPECT_EQ(c.spec_key, s.spec->key());
  EXPECT_EQ(c.parameters.size(), to_map(s.spec->base_parameters()).size());  // searched and fixed values
  s.in_flight[5] = s.in_flight[4];
  EXPECT_NE(s.candidate(99, 4).rollout.seed, s.candidate(99, 5).rollout.seed);  // a seed per trial
  EXPECT_EQ(s.candidate(99, 4).rollout.seed, s.candidate(99, 4).rollout.seed);
}

TEST(LockstepModel, ProposesTrialKOnlyOnceTrialsUpToKMinusNMinusOneReported) {
  StudyRun s = run_of("name: p\nbudget: 20\ninitial_points: 4\nlockstep: 2\n");
  const Eigen::VectorXd x = Eigen::VectorXd::Zero(s.config.space.size());
  EXPECT_EQ(LockstepModel::room(s), 2);  // nothing reported: trials 0 and 1 may be proposed
  s.next_trial_id = 2;
  EXPECT_EQ(LockstepModel::room(s), 0);
  s.untold.emplace_back(1, bo::Observation{x, 1.0});  // trial 1 first: a gap at 0, nothing tellable
  EXPECT_EQ(LockstepModel::tellable(s), 0);
  EXPECT_EQ(LockstepModel::room(s), 0);
  s.untold.emplace_back(0, bo::Observation{x, 1.0});
  EXPECT_EQ(LockstepModel::tellable(s), 2);
  EXPECT_EQ(LockstepModel::room(s), 2);
  const LockstepModel lockstep;
  EXPECT_TRUE(lockstep.worth_a_job(s, 1));
  EXPECT_FALSE(lockstep.worth_a_job(s, 0));  // reports wait for the ask that needs them
  EXPECT_NE(dynamic_cast<const LockstepModel*>(&strategy_for(s)), nullptr);
  StudyRun async = run_of("name: p\nbudget: 20\ninitial_points: 4\n");
  EXPECT_NE(dynamic_cast<const AsynchronousModel*>(&strategy_for(async)), nullptr);
}

struct Recording : Outbox {
  std::vector<domain::Candidate> candidates;
  void send_candidate(const domain::Candidate& c) override { candidates.push_back(c); }
  void retire_candidate(const domain::Candidate&) override {}
  void publish_trial(const domain::TrialRecord&) override {}
  void retire_trial(const domain::TrialRecord&) override {}
  void publish_state(const domain::StudyState&) override {}
  void reply(const domain::CommandReply&) override {}
};

TEST(Dispatcher, WritesAtMostTheTickCapStoresBeforeSendingAndKeepsHardwareSlotsForHardwareWork) {
  const std::string path = (std::filesystem::temp_directory_path() / ("parts-" + std::to_string(getpid()) + ".db")).string();
  std::filesystem::remove(path);
  {
    study::StudyStore store(path);
    Recording out;
    WorkerPool pool;
    pool.announce("sim-a", 1, 2, false, true, "", 0.0);
    pool.announce("sim-b", 2, 2, false, true, "", 0.0);
    pool.announce("robot", 3, 1, true, true, "", 0.0);
    Dispatcher dispatcher(store, out, pool, [] { return 1.7e9; });
    StudyRun s = run_of("name: p\nbudget: 20\ninitial_points: 4\n");
    s.id = store.create_study("p", "name: p\n", "p.yaml", 1.7e9);
    for (int i = 0; i < 5; ++i) s.proposed.push_back(Eigen::VectorXd::Constant(s.config.space.size(), 0.1 * i));
    dispatcher.start_tick(3);
    FreeSlots free = dispatcher.issue_waiting_work({&s}, 0.0);
    ASSERT_EQ(out.candidates.size(), 3u);  // the cap, though four simulation slots are free
    EXPECT_EQ(free.simulation, 1);
    EXPECT_EQ(free.hardware, 1);  // a simulation study's points never go to the robot
    for (const auto& c : out.candidates) EXPECT_NE(c.worker_id, "robot");
    EXPECT_EQ(store.load(s.id)->trials.size(), 3u);  // in the store before they were sent
    EXPECT_EQ(s.proposed.size(), 2u);
    dispatcher.start_tick(3);
    free = dispatcher.issue_waiting_work({&s}, 0.0);
    EXPECT_EQ(out.candidates.size(), 4u);  // the last free simulation slot
    EXPECT_EQ(free.simulation, 0);
  }
  for (const char* suffix : {"", "-wal", "-shm"}) std::filesystem::remove(path + suffix);
}

TEST(ReplyCache, AnswersARepeatedCommandAndForgetsTheOldestBeyondItsCapacity) {
  ReplyCache cache(2);
  domain::StudyCommand a{1, "cli", domain::CommandKind::kSubmit, 0, "", "", 0, {}};
  domain::StudyCommand b{2, "cli", domain::CommandKind::kStop, 3, "", "", 0, {}};
  domain::StudyCommand c{1, "other", domain::CommandKind::kPause, 3, "", "", 0, {}};  // same id, another client
  cache.remember(a, domain::CommandReply{1, "cli", true, 7, "study 7 accepted"});
  EXPECT_EQ(cache.find(a)->study_id, 7);
  EXPECT_FALSE(cache.find(c).has_value());
  cache.remember(b, domain::CommandReply{2, "cli", true, 3, "stopped"});
  cache.remember(c, domain::CommandReply{1, "other", false, 3, "no"});
  EXPECT_FALSE(cache.find(a).has_value());  // the oldest went
  EXPECT_TRUE(cache.find(b).has_value());
  EXPECT_EQ(cache.size(), 2u);
}

}  // namespace
}  // namespace cpgmatch::service
