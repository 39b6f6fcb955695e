// Mixed studies (issue 10): exploration on simulation workers, the validation phase on hardware
// workers, waiting for hardware, restarts mid-validation, and the study file's `validation` key.
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <unistd.h>

#include <filesystem>
#include <set>
#include <vector>

#include "cpgmatch/domain/worker_identity.hpp"
#include "cpgmatch/errors.hpp"
#include "cpgmatch/service/coordinator.hpp"
#include "cpgmatch/service/validation_sets.hpp"
#include "coordinator_test_support.hpp"

namespace cpgmatch::service {
namespace {

using test_support::RecordingOutbox;
using test_support::study_error;

constexpr const char* kMixedStudy =
    "name: mixed\nbudget: 6\ninitial_points: 3\nseed: 7\nrollout: {entrain_s: 1, eval_s: 1}\n"
    "validation: {hardware_sets: 4, spread: 0.1}\n";

class MixedStudyTest : public test_support::CoordinatorFixture {
 protected:
  MixedStudyTest() : CoordinatorFixture("mixed") {}
  // Keeps both workers alive (as their heartbeats would).
  void heartbeat() {
    worker("sim", sim_slots_, domain::WorkerKind::kSimulation);
    if (hardware_) worker("robot", 1, domain::WorkerKind::kHardware);
  }
  // Answers every candidate not answered yet; sim rollouts cost 1 + trial / 10, hardware ones 4 + ...
  void answer_all() {
    while (answered_ < out_.candidates.size()) {
      const domain::Candidate& c = out_.candidates[answered_++];
      const bool hw = c.worker_id == "robot";
      coordinator_->handle_report(
          test_support::completed_report(c, (hw ? 4.0 : 1.0) + 0.1 * c.id.trial_id,
                                         hw ? domain::WorkerKind::kHardware : domain::WorkerKind::kSimulation),
          now_);
    }
  }
  void run(int rounds) {
    for (int i = 0; i < rounds; ++i) {
      heartbeat();
      coordinator_->tick(now_ += 0.2);
      answer_all();
    }
    heartbeat();
    coordinator_->tick(now_ += 0.2);
  }
  // Submits kMixedStudy, runs it for 20 rounds and returns what the store then holds: a finished study.
  study::StoredStudy run_mixed_study_to_the_end() {
    const int id = submit(kMixedStudy);
    run(20);
    const auto s = store_->load(id);
    if (!s) {
      ADD_FAILURE() << "study " << id << " is not in the store";
      return {};
    }
    EXPECT_EQ(s->state, "done") << s->message;
    return *s;
  }
  std::vector<const study::StoredTrial*> phase(const study::StoredStudy& s, const std::string& p) {
    std::vector<const study::StoredTrial*> out;
    for (const auto& t : s.trials) {
      if (t.phase == p) out.push_back(&t);
    }
    return out;
  }

  bool hardware_ = true;
  int sim_slots_ = 2;
};

TEST_F(MixedStudyTest, ExplorationGoesToSimulationAndTheValidationSetsToHardwareAroundTheAnswer) {
  const study::StoredStudy s = run_mixed_study_to_the_end();
  const auto explored = phase(s, "exploration");
  const auto validated = phase(s, "validation");
  ASSERT_EQ(explored.size(), 6);
  ASSERT_EQ(validated.size(), 4);
  for (const auto* t : explored) EXPECT_EQ(t->worker_id, "sim") << "trial " << t->trial_id;
  for (const auto* t : validated) {
    EXPECT_EQ(t->worker_id, "robot") << "trial " << t->trial_id;
    EXPECT_EQ(t->status, study::TrialStatus::kDone);
    EXPECT_GT(t->trial_id, explored.back()->trial_id);  // only after the exploration
  }
  // Around the recommendation (every sim cost rises with the trial id, so the GP's lowest posterior mean
  // is at an early trial): each parameter within +-10 % of the centre's and inside the bounds.
  const domain::StudyState& last = out_.states.back();
  EXPECT_EQ(last.status, domain::StudyStatus::kDone);
  EXPECT_EQ(last.budget, 10);
  EXPECT_EQ(last.completed, 10);
  ASSERT_TRUE(last.has_recommendation);
  const int centre_trial = last.recommendation.trial;
  const Eigen::VectorXd centre = s.trials.at(static_cast<std::size_t>(centre_trial)).x;
  const auto cfg = study::load_study_config_text(kMixedStudy, "s.yaml");
  for (const auto* t : validated) {
    for (int d = 0; d < centre.size(); ++d) {
      EXPECT_LE(std::abs(t->x[d] - centre[d]), 0.1 * std::abs(centre[d]) + 1e-12) << "dim " << d;
      EXPECT_GE(t->x[d], cfg.space.dimensions()[d].low);
      EXPECT_LE(t->x[d], cfg.space.dimensions()[d].high);
    }
  }
}

TEST_F(MixedStudyTest, TheValidationReachesTheRobotWhileManySimulationSlotsSitIdle) {
  // More idle simulation slots than candidates a tick may write (max_issues_per_tick): the cap counts
  // candidates written, not slots offered, so the hardware sets still go out.
  sim_slots_ = 3 * CoordinatorOptions{}.max_issues_per_tick;
  const study::StoredStudy s = run_mixed_study_to_the_end();
  const auto validated = phase(s, "validation");
  ASSERT_EQ(validated.size(), 4);
  for (const auto* t : validated) EXPECT_EQ(t->worker_id, "robot") << "trial " << t->trial_id;
}

TEST_F(MixedStudyTest, ValidationSetsAreWithinTheSpreadAndBoundsAndTheSameForTheSameSeed) {
  const bo::SearchSpace space({{"a", 0.0, 1.0, false, ""}, {"b", -1.0, 1.0, false, ""}, {"c", 0.5, 2.0, false, ""}});
  Eigen::VectorXd centre(3);
  centre << 0.98, 0.0, 1.0;  // a near its upper bound, b zero
  const auto sets = validation_sets(space, centre, 50, 0.1, 3);
  ASSERT_EQ(sets.size(), 50);
  bool some_clipped = false, some_varied = false;
  for (const auto& x : sets) {
    EXPECT_LE(x[0], 1.0);
    EXPECT_GE(x[0], 0.98 * 0.9 - 1e-12);
    some_clipped |= x[0] == 1.0;
    EXPECT_EQ(x[1], 0.0);  // relative: zero stays zero
    EXPECT_LE(std::abs(x[2] - 1.0), 0.1 + 1e-12);
    some_varied |= std::abs(x[2] - 1.0) > 0.05;
  }
  EXPECT_TRUE(some_clipped);
  EXPECT_TRUE(some_varied);
  const auto again = validation_sets(space, centre, 50, 0.1, 3);
  const auto other = validation_sets(space, centre, 50, 0.1, 4);
  for (std::size_t i = 0; i < sets.size(); ++i) EXPECT_EQ(sets[i], again[i]);
  EXPECT_NE(sets[0], other[0]);
  for (const auto& x : validation_sets(space, centre, 5, 0.0, 3)) EXPECT_EQ(x, centre);  // spread 0
}

TEST_F(MixedStudyTest, WithoutAHardwareWorkerTheValidationWaitsAndSaysSo) {
  hardware_ = false;
  const int id = submit(kMixedStudy);
  run(20);
  auto s = store_->load(id);
  ASSERT_TRUE(s);
  EXPECT_EQ(s->state, "running");
  EXPECT_EQ(phase(*s, "validation").size(), 4);  // stored, waiting
  const domain::StudyState& waiting = out_.states.back();
  EXPECT_EQ(waiting.status, domain::StudyStatus::kRunning);
  EXPECT_EQ(waiting.completed, 6);
  EXPECT_EQ(waiting.message.rfind("waiting_for_hardware", 0), 0u) << waiting.message;
  for (const auto& c : out_.candidates) EXPECT_EQ(c.worker_id, "sim");  // never to the sim worker
  hardware_ = true;  // the robot joins
  run(10);
  s = store_->load(id);
  EXPECT_EQ(s->state, "done") << s->message;
  EXPECT_EQ(out_.states.back().message.find("waiting"), std::string::npos);
}

TEST_F(MixedStudyTest, ARestartMidValidationIssuesTheSameSetsAndCountsEachOnce) {
  const int id = submit(kMixedStudy);
  // Exploration, then the first validation set reported; the second is in flight at the "crash".
  for (int i = 0; i < 40; ++i) {
    heartbeat();
    coordinator_->tick(now_ += 0.2);
    const auto s = store_->load(id);
    int hw_done = 0;
    for (const auto& t : s->trials) hw_done += t.phase == "validation" && t.status == study::TrialStatus::kDone;
    if (hw_done == 1) break;
    // Answer one candidate at a time so that the crash falls between two validation reports.
    if (answered_ < out_.candidates.size()) {
      const std::size_t upto = answered_ + 1;
      std::vector<domain::Candidate> rest(out_.candidates.begin() + static_cast<long>(upto), out_.candidates.end());
      out_.candidates.resize(upto);
      answer_all();
      out_.candidates.insert(out_.candidates.end(), rest.begin(), rest.end());
    }
  }
  const auto before = store_->load(id);
  int done_before = 0;
  for (const auto* t : phase(*before, "validation")) done_before += t->status == study::TrialStatus::kDone;
  ASSERT_EQ(done_before, 1);  // the "crash" falls mid-validation
  std::vector<Eigen::VectorXd> sets_before;
  for (const auto* t : phase(*before, "validation")) sets_before.push_back(t->x);
  ASSERT_EQ(sets_before.size(), 4);
  open();
  coordinator_->resume_from_store(now_);
  run(20);
  const auto after = store_->load(id);
  EXPECT_EQ(after->state, "done") << after->message;
  const auto validated = phase(*after, "validation");
  ASSERT_EQ(validated.size(), 4);  // the same four, no fresh draw
  for (std::size_t i = 0; i < validated.size(); ++i) EXPECT_EQ(validated[i]->x, sets_before[i]);
  EXPECT_EQ(phase(*after, "exploration").size(), 6);
  EXPECT_EQ(out_.states.back().completed, 10);
}

TEST_F(MixedStudyTest, AHardwareOnlyStudyNeverUsesSimulationWorkers) {
  const int id = submit("name: hw\nbudget: 3\ninitial_points: 3\nexplore_on: hardware\n"
                        "rollout: {entrain_s: 1, eval_s: 1}\n");
  run(20);
  const auto s = store_->load(id);
  EXPECT_EQ(s->state, "done") << s->message;
  ASSERT_EQ(s->trials.size(), 3);
  for (const auto& t : s->trials) EXPECT_EQ(t.worker_id, "robot");
}

TEST_F(MixedStudyTest, AStoreWithoutThePhaseColumnIsMigratedInPlace) {
  const int id = submit("name: old\nbudget: 2\ninitial_points: 2\nrollout: {entrain_s: 1, eval_s: 1}\n");
  run(5);
  coordinator_.reset();
  store_.reset();
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path_.c_str(), &db), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(db, "ALTER TABLE trials DROP COLUMN phase", nullptr, nullptr, nullptr), SQLITE_OK);
  sqlite3_close(db);
  open();  // an older store: the column comes back, every trial an exploration
  const auto s = store_->load(id);
  ASSERT_EQ(s->trials.size(), 2);
  for (const auto& t : s->trials) EXPECT_EQ(t.phase, "exploration");
}

TEST(MixedStudyConfig, ValidationKeysHaveDefaultsAndRangesNamedWithFileAndLine) {
  const auto none = study::load_study_config_text("name: a\n", "s.yaml");
  EXPECT_FALSE(none.validation.enabled);  // a plain study never waits for hardware
  const auto defaults = study::load_study_config_text("name: a\nvalidation: {}\n", "s.yaml");
  EXPECT_TRUE(defaults.validation.enabled);
  EXPECT_EQ(defaults.validation.hardware_sets, 10);
  EXPECT_DOUBLE_EQ(defaults.validation.spread, 0.10);
  std::string e = study_error("name: a\nvalidation: {hardware_sets: 0}\n");
  EXPECT_NE(e.find("s.yaml:2"), std::string::npos) << e;
  EXPECT_NE(e.find("hardware_sets"), std::string::npos) << e;
  EXPECT_NE(study_error("name: a\nvalidation: {spread: -0.1}\n").find("spread"), std::string::npos);
  EXPECT_NE(study_error("name: a\nvalidation: {spread: 1.5}\n").find("spread"), std::string::npos);
  EXPECT_NE(study_error("name: a\nvalidation: {sets: 3}\n").find("sets"), std::string::npos);
  e = study_error("name: a\nexplore_on: robot\n");
  EXPECT_NE(e.find("explore_on"), std::string::npos) << e;
  EXPECT_EQ(study::load_study_config_text("name: a\nexplore_on: hardware\n", "s.yaml").explore_on,
            study::WorkerKindWanted::kHardware);
}

}  // namespace
}  // namespace cpgmatch::service
