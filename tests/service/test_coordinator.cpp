// The optimizer service's logic without DDS: a Coordinator driven by hand-made samples, with a store in
// a temporary file and an Outbox that records what would be published.
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <algorithm>
#include <atomic>
#include <future>
#include <optional>
#include <set>
#include <vector>

#include "coordinator_test_support.hpp"
#include "cpgmatch/domain/worker_identity.hpp"
#include "cpgmatch/service/coordinator.hpp"

namespace cpgmatch::service {
namespace {

using test_support::submit_command;

struct RecordingOutbox : Outbox {
  std::vector<domain::Candidate> candidates, retired;
  std::vector<domain::TrialRecord> trials, retired_trials;
  std::vector<domain::StudyState> states;
  std::vector<domain::CommandReply> replies;
  void send_candidate(const domain::Candidate& c) override { candidates.push_back(c); }
  void retire_candidate(const domain::Candidate& c) override { retired.push_back(c); }
  void publish_trial(const domain::TrialRecord& t) override { trials.push_back(t); }
  void retire_trial(const domain::TrialRecord& t) override { retired_trials.push_back(t); }
  void publish_state(const domain::StudyState& s) override { states.push_back(s); }
  void reply(const domain::CommandReply& r) override { replies.push_back(r); }
};

class CoordinatorTest : public ::testing::Test {
 protected:
  void SetUp() override {
    path_ = (std::filesystem::temp_directory_path() / ("coordinator-" + std::to_string(getpid()) + "-" +
                                                       ::testing::UnitTest::GetInstance()->current_test_info()->name() + ".db")).string();
    std::filesystem::remove(path_);
    open();
  }
  void TearDown() override {
    coordinator_.reset();
    store_.reset();
    for (const char* suffix : {"", "-wal", "-shm"}) std::filesystem::remove(path_ + suffix);
  }
  // (Re)opens store and coordinator on the same file, as a restarted service would.
  void open() {
    coordinator_.reset();
    store_ = std::make_unique<study::StudyStore>(path_);
    out_ = RecordingOutbox{};
    deferred_ = std::make_unique<DeferredOutbox>(out_);
    CoordinatorOptions options;
    options.wall_clock_s = [this] { return wall_; };
    options.model_threads = model_threads_;
    options.model_job_hook = model_job_hook_;
    options.require_authenticated_workers = require_identity_;
    options.resolve_specs_off_thread = resolve_off_thread_;
    coordinator_ = std::make_unique<Coordinator>(*store_, defer_ ? static_cast<Outbox&>(*deferred_) : out_, options,
                                                 [this](const std::string& m) { infos_.push_back(m); },
                                                 [this](const std::string& m) { warnings_.push_back(m); });
  }
  int submit(int budget, int initial) {
    domain::StudyCommand c = submit_command("name: t\nbudget: " + std::to_string(budget) + "\ninitial_points: " + std::to_string(initial) +
                 "\nrollout: {entrain_s: 1, eval_s: 1}\n" + extra_study_yaml_, ++correlation_);
    coordinator_->handle_command(c, now_);
    EXPECT_TRUE(out_.replies.back().ok) << out_.replies.back().message;
    return static_cast<int>(out_.replies.back().study_id);
  }
  std::string extra_study_yaml_;  // appended to submit()'s study file
  int fall_every_ = 0;            // one_slot_study: every n-th trial falls (0: none)
  std::vector<std::map<std::string, double>> one_slot_study(int answers, int restart_after);
  std::vector<std::map<std::string, double>> four_slot_study(bool restart_before_the_last_job);
 public:
  std::map<int, std::map<std::string, double>> run_two_worker_study(int lockstep, bool newest_first,
                                                                    int restart_at_step = -1) {
    coordinator_.reset();
    store_.reset();
    for (const char* suffix : {"", "-wal", "-shm"}) std::filesystem::remove(path_ + suffix);
    open();
    domain::StudyCommand c = submit_command("name: t\nbudget: 24\ninitial_points: 6\nlockstep: " + std::to_string(lockstep) +
                 "\nrollout: {entrain_s: 1, eval_s: 1}\n", ++correlation_);
    coordinator_->handle_command(c, now_);
    EXPECT_TRUE(out_.replies.back().ok) << out_.replies.back().message;
    worker("a", 1);
    worker("b", 1);
    settle(now_ += 0.01);
    std::map<int, std::map<std::string, double>> issued;
    std::map<int, domain::Candidate> outstanding;
    std::size_t seen = 0;
    for (int step = 0; step < 200; ++step) {
      for (; seen < out_.candidates.size(); ++seen) {
        const domain::Candidate& cand = out_.candidates[seen];
        issued[cand.id.trial_id] = cand.parameters;
        outstanding[cand.id.trial_id] = cand;
      }
      if (outstanding.empty()) break;
      if (step == restart_at_step) {
        // kill -9 and restart: the store is all that is left; in-flight candidates go out again.
        open();
        coordinator_->resume_from_store(now_);
        worker("a", 1);
        worker("b", 1);
        settle(now_ += 0.01);
        seen = 0;
        outstanding.clear();
        for (; seen < out_.candidates.size(); ++seen) {
          const domain::Candidate& cand = out_.candidates[seen];
          EXPECT_EQ(cand.parameters, issued.at(cand.id.trial_id));
          outstanding[cand.id.trial_id] = cand;
        }
      }
      const auto pick = newest_first ? std::prev(outstanding.end()) : outstanding.begin();
      double cost = 0.5;
      for (const auto& [name, value] : issued.at(pick->first)) cost += (value - 0.3) * (value - 0.3);
      coordinator_->handle_report(report_for(pick->second, cost), now_);
      outstanding.erase(pick);
      settle(now_ += 0.01);
    }
    return issued;
  }
 protected:
  // A tick, then with model threads: wait for the model jobs it started and tick again until none is left
  // (what the service's event loop does as results arrive). Without model threads: just the tick.
  void settle(double now_s) {
    coordinator_->tick(now_s);
    while (coordinator_->model_jobs_outstanding() > 0) {
      coordinator_->wait_for_models();
      coordinator_->tick(now_s);
    }
  }
  void worker(const std::string& id, int slots, const std::optional<std::string>& identity = std::nullopt) {
    domain::WorkerAnnouncement w;
    w.worker_id = id;
    w.worker_key = domain::worker_key(id);
    w.slots = slots;
    w.accepting = true;
    coordinator_->handle_worker(w, now_, identity);
  }
  // Candidates sent so far to `worker_id`.
  std::vector<domain::Candidate> sent_to(const std::string& worker_id) const {
    std::vector<domain::Candidate> to;
    for (const auto& c : out_.candidates) {
      if (c.worker_id == worker_id) to.push_back(c);
    }
    return to;
  }
  domain::RolloutReport report_for(const domain::Candidate& c, double cost) {
    domain::RolloutReport r;
    r.id = c.id;
    r.worker_id = c.worker_id;
    r.summary.cost = cost;
    r.summary.terms = CostTerms{};  // zero terms, nothing moved: a synthetic measurement
    r.summary.distance_m = 0.0;
    return r;
  }
  // A report of `outcome` for a candidate: refused, plant_fault or diverged did not measure the point.
  domain::RolloutReport unspent_report(const domain::Candidate& c, domain::Outcome outcome, const std::string& why) {
    domain::RolloutReport r = report_for(c, std::nan(""));
    // ok follows the outcome
    r.outcome = outcome;
    r.error = why;
    return r;
  }
  // Answers every candidate sent so far that has not been answered yet.
  void answer_all(double cost = 1.0) {
    while (answered_ < out_.candidates.size()) {
      coordinator_->handle_report(report_for(out_.candidates[answered_], cost + answered_ * 0.01), now_);
      ++answered_;
    }
  }
  std::string path_;
  std::unique_ptr<study::StudyStore> store_;
  RecordingOutbox out_;
  std::unique_ptr<DeferredOutbox> deferred_;  // between the coordinator and out_ when defer_ (the service's setup)
  bool defer_ = false;
  std::unique_ptr<Coordinator> coordinator_;
  std::vector<std::string> warnings_;
  std::vector<std::string> infos_;
  std::size_t answered_ = 0;
  std::uint64_t correlation_ = 0;
  double now_ = 1000.0;       // monotonic time handed to the coordinator
  double wall_ = 1.7e9;       // the wall clock it writes to the store
  int model_threads_ = 0;     // 0: model jobs inline
  bool require_identity_ = false;  // as with DDS-Security on
  bool resolve_off_thread_ = false;  // as the service runs: submitted specs resolved on a model thread
  std::function<void(int)> model_job_hook_;
};

TEST_F(CoordinatorTest, FillsEveryFreeSlotAndFinishesWithExactlyTheBudget) {
  const int id = submit(10, 4);
  worker("a", 3);
  worker("b", 2);
  coordinator_->tick(now_);
  ASSERT_EQ(out_.candidates.size(), 5);  // every slot busy
  int to_a = 0;
  for (const auto& c : out_.candidates) to_a += c.worker_id == "a";
  EXPECT_EQ(to_a, 3);
  for (int round = 0; round < 10 && !coordinator_->idle(); ++round) {
    answer_all();
    coordinator_->tick(now_ += 0.2);
  }
  EXPECT_EQ(out_.candidates.size(), 10);
  EXPECT_EQ(out_.trials.size(), 10);
  const auto done = store_->load(id);
  ASSERT_TRUE(done);
  EXPECT_EQ(done->state, "done");
  EXPECT_EQ(out_.states.back().completed, 10);
  EXPECT_EQ(out_.states.back().status, domain::StudyStatus::kDone);
  // Every candidate carries the complete CPG parameter set.
  EXPECT_EQ(out_.candidates[0].parameters.size(), 8);
}

// A study with two one-slot workers whose reports are answered oldest-first or newest-first; the cost is
// a smooth function of the point. Returns the point issued for each trial id.
std::map<int, std::map<std::string, double>> two_worker_study(CoordinatorTest& t, int lockstep, bool newest_first,
                                                              int restart_at_step = -1);

TEST_F(CoordinatorTest, ALockstepStudyIsTheSameWhateverOrderItsReportsArriveIn) {
  const auto oldest = two_worker_study(*this, 2, false);
  const auto newest = two_worker_study(*this, 2, true);
  ASSERT_EQ(oldest.size(), 24);
  ASSERT_EQ(newest.size(), 24);
  for (const auto& [trial, point] : oldest) EXPECT_EQ(point, newest.at(trial)) << "trial " << trial;
  // Asynchronous, the same two orders take different paths once the model is used: what lockstep is for.
  const auto async_oldest = two_worker_study(*this, 0, false);
  const auto async_newest = two_worker_study(*this, 0, true);
  int differ = 0;
  for (const auto& [trial, point] : async_oldest) differ += async_newest.count(trial) && point != async_newest.at(trial);
  EXPECT_GT(differ, 0);
}

TEST_F(CoordinatorTest, ALockstepStudyRestartedMidwayIsTheSameStudy) {
  const auto straight = two_worker_study(*this, 2, true);
  for (const int restart_at : {5, 13}) {  // in the initial design, and with the model in use
    const auto restarted = two_worker_study(*this, 2, true, restart_at);
    ASSERT_EQ(restarted.size(), straight.size()) << "restart at " << restart_at;
    for (const auto& [trial, point] : straight) EXPECT_EQ(point, restarted.at(trial)) << "trial " << trial << ", restart at " << restart_at;
  }
}

TEST_F(CoordinatorTest, APausedLockstepStudyStartsNoModelJobsAndGoesOnWhenResumed) {
  int jobs = 0;
  model_job_hook_ = [&jobs](int) { ++jobs; };
  open();  // with the hook
  domain::StudyCommand c = submit_command("name: t\nbudget: 10\ninitial_points: 4\nlockstep: 2\nrollout: {entrain_s: 1, eval_s: 1}\n", ++correlation_);
  coordinator_->handle_command(c, now_);
  const auto id = out_.replies.back().study_id;
  worker("a", 2);
  settle(now_ += 0.01);
  ASSERT_EQ(out_.candidates.size(), 2);
  domain::StudyCommand pause;
  pause.correlation_id = ++correlation_;
  pause.client_id = "test";
  pause.kind = domain::CommandKind::kPause;
  pause.study_id = id;
  coordinator_->handle_command(pause, now_);
  answer_all();  // both reports arrive while paused: they wait, untold
  const int jobs_when_paused = jobs;
  for (int i = 0; i < 20; ++i) settle(now_ += 0.1);
  EXPECT_EQ(jobs, jobs_when_paused) << "a paused lockstep study ran model jobs";
  EXPECT_EQ(out_.candidates.size(), 2);
  pause.kind = domain::CommandKind::kResume;
  pause.correlation_id = ++correlation_;
  coordinator_->handle_command(pause, now_);
  for (int round = 0; round < 40 && out_.states.back().completed < 10; ++round) {
    answer_all();
    settle(now_ += 0.1);
  }
  EXPECT_EQ(out_.states.back().completed, 10);
  EXPECT_EQ(out_.candidates.size(), 10);
}

TEST_F(CoordinatorTest, DuplicateAndForgedReportsAreNotCounted) {
  submit(5, 5);
  worker("a", 2);
  coordinator_->tick(now_);
  ASSERT_EQ(out_.candidates.size(), 2);
  const domain::RolloutReport first = report_for(out_.candidates[0], 3.0);
  coordinator_->handle_report(first, now_);
  coordinator_->handle_report(first, now_);  // duplicate
  domain::RolloutReport future = report_for(out_.candidates[1], 2.0);
  future.id.attempt = 7;  // an attempt that was never issued
  coordinator_->handle_report(future, now_);
  domain::RolloutReport never = report_for(out_.candidates[1], 2.0);
  never.id.trial_id = 99;
  coordinator_->handle_report(never, now_);
  EXPECT_EQ(out_.trials.size(), 1);
  EXPECT_EQ(coordinator_->rejected_samples(), 2u);
  coordinator_->tick(now_ += 1);
  EXPECT_EQ(out_.states.back().completed, 1);
}

TEST_F(CoordinatorTest, ANonPositiveCostIsRefusedInALogCostStudyAndTheTrialCanStillBeAnswered) {
  submit(3, 3);  // studies model log(cost) by default
  worker("a", 1);
  coordinator_->tick(now_);
  ASSERT_EQ(out_.candidates.size(), 1);
  coordinator_->handle_report(report_for(out_.candidates[0], 0.0), now_);
  coordinator_->handle_report(report_for(out_.candidates[0], -2.5), now_);
  EXPECT_EQ(out_.trials.size(), 0);
  EXPECT_EQ(coordinator_->rejected_samples(), 2u);
  ASSERT_FALSE(warnings_.empty());
  EXPECT_NE(warnings_.back().find("must be > 0"), std::string::npos) << warnings_.back();
  coordinator_->handle_report(report_for(out_.candidates[0], 1.5), now_);  // the real result still counts
  EXPECT_EQ(out_.trials.size(), 1);
}

TEST_F(CoordinatorTest, AReportCountsOnlyFromTheWorkerItsCandidateWasAssignedTo) {
  submit(4, 4);
  worker("a", 1);
  worker("b", 1);
  coordinator_->tick(now_);
  ASSERT_EQ(out_.candidates.size(), 2);
  const domain::Candidate to_a = out_.candidates[0].worker_id == "a" ? out_.candidates[0] : out_.candidates[1];
  // Any participant can read the candidates; answering one that went to someone else must not count.
  domain::RolloutReport forged = report_for(to_a, -1000.0);
  forged.worker_id = "b";  // another live worker
  coordinator_->handle_report(forged, now_);
  forged.worker_id = "intruder";  // no worker at all
  coordinator_->handle_report(forged, now_);
  EXPECT_EQ(out_.trials.size(), 0);
  EXPECT_EQ(coordinator_->rejected_samples(), 2u);
  // The assigned worker's own report still counts, once.
  coordinator_->handle_report(report_for(to_a, 1.0), now_);
  ASSERT_EQ(out_.trials.size(), 1);
  EXPECT_EQ(out_.trials[0].report.worker_id, "a");
  EXPECT_DOUBLE_EQ(out_.trials[0].report.summary.cost, 1.0);
  coordinator_->tick(now_ += 1);
  EXPECT_EQ(out_.states.back().completed, 1);
}

TEST_F(CoordinatorTest, WithSecurityAReportCountsOnlyWhenTheSendersCertificateOwnsItsWorkerId) {
  require_identity_ = true;
  open();
  submit(4, 4);
  // Announcements: only from a sender whose certificate owns the id.
  worker("a", 1);                 // no authenticated identity at all
  worker("a", 1, "mallory");      // another identity claiming a
  worker("node12/2", 1, "node");  // CN "node" does not own "node12/...": the CN is not a mere prefix
  EXPECT_EQ(coordinator_->live_workers(), 0);
  EXPECT_EQ(coordinator_->rejected_samples(), 3u);
  ASSERT_FALSE(warnings_.empty());
  EXPECT_NE(warnings_.back().find("CN=node, which does not own worker id 'node12/2'"), std::string::npos)
      << warnings_.back();
  worker("a", 1, "a");
  worker("node12/2", 1, "node12");  // an instance of identity node12
  EXPECT_EQ(coordinator_->live_workers(), 2);
  coordinator_->tick(now_);
  ASSERT_EQ(sent_to("a").size(), 1);
  ASSERT_EQ(sent_to("node12/2").size(), 1);
  const domain::Candidate to_a = sent_to("a")[0];
  // A participant with a valid certificate for another identity writes a's report: never counted, whatever
  // its cost; nor one whose sender is unknown.
  const domain::RolloutReport forged = report_for(to_a, 1e-6);
  coordinator_->handle_report(forged, now_, std::string("mallory"));
  coordinator_->handle_report(forged, now_, std::string("node12"));
  coordinator_->handle_report(forged, now_, std::nullopt);
  coordinator_->handle_report(forged, now_, std::string(""));
  EXPECT_EQ(out_.trials.size(), 0);
  EXPECT_EQ(coordinator_->rejected_samples(), 7u);
  EXPECT_NE(warnings_.back().find("certificate is not known"), std::string::npos) << warnings_.back();
  // The owners' own reports count, once each.
  coordinator_->handle_report(report_for(to_a, 2.0), now_, std::string("a"));
  coordinator_->handle_report(report_for(sent_to("node12/2")[0], 3.0), now_, std::string("node12"));
  ASSERT_EQ(out_.trials.size(), 2);
  EXPECT_DOUBLE_EQ(out_.trials[0].report.summary.cost, 2.0);
  coordinator_->tick(now_ += 1);
  EXPECT_EQ(out_.states.back().completed, 2);
  EXPECT_EQ(out_.states.back().best_cost, 2.0);
}

TEST_F(CoordinatorTest, AWorkerThatShutsDownCleanlyIsLoggedAsLeavingAndALostOneAsLost) {
  open();
  submit(4, 4);
  worker("a", 1);
  worker("b", 1);
  coordinator_->tick(now_);
  ASSERT_EQ(sent_to("a").size(), 1);
  ASSERT_EQ(sent_to("b").size(), 1);
  coordinator_->handle_worker_gone(domain::worker_key("a"), now_, WorkerExit::kLeft);
  coordinator_->handle_worker_gone(domain::worker_key("b"), now_, WorkerExit::kLost);
  EXPECT_EQ(coordinator_->live_workers(), 0);
  const auto logged = [&](const std::string& text) {
    return std::any_of(infos_.begin(), infos_.end(), [&](const std::string& m) { return m.find(text) != std::string::npos; });
  };
  EXPECT_TRUE(logged("worker a left: it shut down cleanly with 1 candidates assigned"));
  EXPECT_TRUE(logged("worker b lost: its writers vanished"));
  EXPECT_FALSE(logged("silent"));
  // Either way its candidate goes to the next worker.
  worker("c", 2);
  coordinator_->tick(now_ += 0.1);
  EXPECT_EQ(sent_to("c").size(), 2);
}

TEST_F(CoordinatorTest, WithSecurityOnlyTheWorkersOwnIdentityMayDisposeItsAnnouncement) {
  require_identity_ = true;
  open();
  submit(4, 4);
  worker("a", 1, "a");
  coordinator_->tick(now_);
  ASSERT_EQ(sent_to("a").size(), 1);
  coordinator_->handle_worker_gone(domain::worker_key("a"), now_, WorkerExit::kLeft, std::string("mallory"));
  coordinator_->handle_worker_gone(domain::worker_key("a"), now_, WorkerExit::kLeft, std::string(""));
  EXPECT_EQ(coordinator_->live_workers(), 1);
  EXPECT_EQ(coordinator_->rejected_samples(), 2u);
  coordinator_->tick(now_ += 0.1);
  EXPECT_EQ(out_.candidates.size(), 1);  // nothing re-issued
  coordinator_->handle_worker_gone(domain::worker_key("a"), now_, WorkerExit::kLeft, std::string("a"));  // its own dispose
  EXPECT_EQ(coordinator_->live_workers(), 0);
  worker("b", 1, "b");
  coordinator_->handle_worker_gone(domain::worker_key("b"), now_, WorkerExit::kLost, std::nullopt);  // no writer left: no claim
  EXPECT_EQ(coordinator_->live_workers(), 0);
}

TEST_F(CoordinatorTest, WithoutSecurityTheSendersIdentityIsNotChecked) {
  submit(2, 2);
  worker("a", 1, "someone-else");  // there is no identity without security: taken as written
  coordinator_->tick(now_);
  ASSERT_EQ(sent_to("a").size(), 1);
  coordinator_->handle_report(report_for(sent_to("a")[0], 2.0), now_, std::nullopt);
  EXPECT_EQ(out_.trials.size(), 1);
  EXPECT_EQ(coordinator_->rejected_samples(), 0u);
}

TEST_F(CoordinatorTest, AWorkerWhoseLeaseExpiredGetsOneCandidateAtATimeUntilItReports) {
  submit(40, 40);
  worker("greedy", 8);
  coordinator_->tick(now_);
  ASSERT_EQ(sent_to("greedy").size(), 8);
  // It keeps announcing 8 slots but never answers: the leases (60 s + 3 x 2 s) run out.
  for (int i = 0; i < 67; ++i) {
    worker("greedy", 8);
    coordinator_->tick(now_ += 1.0);
  }
  EXPECT_TRUE(coordinator_->on_probation("greedy"));
  // Its 8 candidates were taken back; it got one of them again, not all 8.
  ASSERT_EQ(sent_to("greedy").size(), 9);
  EXPECT_EQ(out_.candidates.back().id.attempt, 1);
  // Leaving and rejoining the domain does not clear it.
  coordinator_->handle_worker_gone(domain::worker_key("greedy"), now_, WorkerExit::kLeft);
  worker("greedy", 8);
  coordinator_->tick(now_ += 0.1);
  EXPECT_EQ(sent_to("greedy").size(), 10);  // the one it held went back and came again: still one at a time
  coordinator_->tick(now_ += 0.1);
  EXPECT_EQ(sent_to("greedy").size(), 10);
  // Another worker gets the rest of the work meanwhile.
  worker("honest", 4);
  coordinator_->tick(now_ += 0.1);
  EXPECT_EQ(sent_to("honest").size(), 4);
  // Its report (for the attempt it holds) ends the probation: all 8 slots again.
  coordinator_->handle_report(report_for(out_.candidates[out_.candidates.size() - 5], 1.0), now_);
  ASSERT_EQ(out_.trials.size(), 1);
  EXPECT_FALSE(coordinator_->on_probation("greedy"));
  coordinator_->tick(now_ += 0.1);
  EXPECT_EQ(sent_to("greedy").size(), 18);
}

TEST_F(CoordinatorTest, AWorkerOnProbationGetsWorkOnlyWhenNoOtherWorkerHasAFreeSlot) {
  submit(3, 3);
  worker("greedy", 3);
  coordinator_->tick(now_);
  ASSERT_EQ(sent_to("greedy").size(), 3);
  for (int i = 0; i < 67; ++i) {  // its three leases expire; it holds one of them again
    worker("greedy", 3);
    coordinator_->tick(now_ += 1.0);
  }
  ASSERT_TRUE(coordinator_->on_probation("greedy"));
  ASSERT_EQ(sent_to("greedy").size(), 4);
  // An honest worker with 2 slots joins: it gets the two waiting re-issues. When greedy's lease expires
  // again, that trial goes to the honest worker (once it has a free slot), not back to greedy.
  worker("honest", 2);
  coordinator_->tick(now_ += 0.1);
  ASSERT_EQ(sent_to("honest").size(), 2);
  for (const auto& c : sent_to("honest")) coordinator_->handle_report(report_for(c, 1.0), now_);
  for (int i = 0; i < 67; ++i) {
    worker("greedy", 3);
    worker("honest", 2);
    coordinator_->tick(now_ += 1.0);
  }
  ASSERT_EQ(sent_to("honest").size(), 3);
  EXPECT_EQ(sent_to("honest").back().id.trial_id, sent_to("greedy").back().id.trial_id);
  EXPECT_EQ(sent_to("greedy").size(), 4);
  coordinator_->handle_report(report_for(sent_to("honest").back(), 1.0), now_);
  coordinator_->tick(now_ += 1.0);
  EXPECT_EQ(out_.states.back().status, domain::StudyStatus::kDone);
}

TEST_F(CoordinatorTest, AfterARestartTheStoredAssignmentStillDecidesWhoMayReport) {
  submit(4, 4);
  worker("a", 1);
  coordinator_->tick(now_);
  ASSERT_EQ(out_.candidates.size(), 1);
  const domain::Candidate in_flight = out_.candidates[0];
  open();  // restart on the same store: the trial is in flight, assigned to a in the store
  coordinator_->resume_from_store(now_);
  domain::RolloutReport forged = report_for(in_flight, -1000.0);
  forged.worker_id = "intruder";
  coordinator_->handle_report(forged, now_);
  EXPECT_EQ(out_.trials.size(), 0);
  coordinator_->handle_report(report_for(in_flight, 1.0), now_);
  EXPECT_EQ(out_.trials.size(), 1);
}

TEST_F(CoordinatorTest, ALostWorkersCandidatesGoToAnotherWorker) {
  submit(6, 6);
  worker("a", 2);
  coordinator_->tick(now_);
  ASSERT_EQ(out_.candidates.size(), 2);
  worker("b", 2);
  coordinator_->handle_worker_gone(domain::worker_key("a"), now_, WorkerExit::kLost);
  coordinator_->tick(now_ += 0.1);
  // The two re-issued candidates (attempt 1) go first, then new ones fill b's remaining slots... b has 2.
  ASSERT_EQ(out_.candidates.size(), 4);
  EXPECT_EQ(out_.candidates[2].worker_id, "b");
  EXPECT_EQ(out_.candidates[2].id.attempt, 1);
  EXPECT_EQ(out_.candidates[2].id.trial_id, out_.candidates[0].id.trial_id);
  // The lost worker's late report still counts once; the re-issued copy's report is then a duplicate.
  coordinator_->handle_report(report_for(out_.candidates[0], 1.0), now_);
  coordinator_->handle_report(report_for(out_.candidates[2], 1.0), now_);
  EXPECT_EQ(out_.trials.size(), 1);
}

TEST_F(CoordinatorTest, SilentWorkerAndExpiredLeaseAreReissued) {
  submit(4, 4);
  worker("a", 1);
  coordinator_->tick(now_);
  ASSERT_EQ(out_.candidates.size(), 1);
  coordinator_->tick(now_ += 10.0);  // no heartbeat for 10 s: a is dropped
  EXPECT_EQ(coordinator_->live_workers(), 0);
  worker("b", 1);
  coordinator_->tick(now_ += 0.1);
  ASSERT_EQ(out_.candidates.size(), 2);
  EXPECT_EQ(out_.candidates[1].id.attempt, 1);
  // b keeps announcing but never reports: the lease (60 s + 3 x 2 s) runs out.
  for (int i = 0; i < 70; ++i) {
    worker("b", 1);
    coordinator_->tick(now_ += 1.0);
  }
  ASSERT_GE(out_.candidates.size(), 3);
  EXPECT_EQ(out_.candidates[2].id.attempt, 2);
  EXPECT_GE(out_.states.back().reissued, 2);
}

TEST_F(CoordinatorTest, RestartResumesWithoutLosingOrDoubleCounting) {
  const int id = submit(8, 3);
  worker("a", 2);
  coordinator_->tick(now_);
  answer_all();
  coordinator_->tick(now_ += 0.1);  // two more issued, still in flight
  ASSERT_EQ(out_.candidates.size(), 4);
  const domain::Candidate in_flight = out_.candidates[2];

  open();  // "crash" and restart on the same store
  coordinator_->resume_from_store(now_);
  EXPECT_EQ(out_.trials.size(), 2);  // the two counted trials are published again
  worker("a", 2);
  // The report of an in-flight candidate, written before the crash, arrives now and counts once.
  coordinator_->handle_report(report_for(in_flight, 0.5), now_);
  coordinator_->handle_report(report_for(in_flight, 0.5), now_);
  EXPECT_EQ(out_.trials.size(), 3);
  answered_ = 0;
  for (int round = 0; round < 20 && !coordinator_->idle(); ++round) {
    coordinator_->tick(now_ += 0.1);
    answer_all();
  }
  coordinator_->tick(now_ += 1);
  const auto s = store_->load(id);
  ASSERT_TRUE(s);
  EXPECT_EQ(s->state, "done");
  EXPECT_EQ(s->trials.size(), 8);
  for (const auto& t : s->trials) EXPECT_EQ(t.status, study::TrialStatus::kDone);
  EXPECT_EQ(out_.states.back().completed, 8);
}

// One worker with one slot, each candidate answered as soon as it is issued (cost from its trial id), for
// `answers` reports; with `restart_after` > 0 the service is restarted on its store after that many.
// Returns the parameters of every candidate issued from the restart point on (or all, without restart).
std::vector<std::map<std::string, double>> CoordinatorTest::one_slot_study(int answers, int restart_after) {
  coordinator_.reset();
  store_.reset();
  for (const char* suffix : {"", "-wal", "-shm"}) std::filesystem::remove(path_ + suffix);
  open();
  submit(answers + 10, 30);
  worker("w", 1);
  std::vector<std::map<std::string, double>> issued;
  settle(now_ += 0.01);
  for (int k = 0; k < answers; ++k) {
    if (k == restart_after && restart_after > 0) {
      open();
      coordinator_->resume_from_store(now_);
      worker("w", 1);
      settle(now_ += 0.01);  // the in-flight candidate goes out again
    }
    const domain::Candidate c = out_.candidates.back();
    if (k >= restart_after) issued.push_back(c.parameters);
    domain::RolloutReport r = report_for(c, 1.0 + std::sin(0.7 * c.id.trial_id) + 0.1);
    if (fall_every_ > 0 && c.id.trial_id % fall_every_ == 0) {
      // fell follows the outcome
      r.outcome = domain::Outcome::kFell;
      r.summary.cost = 15.0;
    }
    coordinator_->handle_report(r, now_ += 0.01);
    settle(now_ += 0.01);
  }
  issued.push_back(out_.candidates.back().parameters);
  return issued;
}

// One worker with 4 slots; every round answers the 4 outstanding candidates, then ticks: the 4 reports wait
// for one model job, which tells them as one batch. 9 rounds (36 reports, the model from report 30 on).
// With restart_before_the_last_job, the service restarts after the 9th round's reports were counted and
// before their job ran: the store's model state lags 4 reports behind them. Returns the parameters of the
// candidates issued by the last tick.
std::vector<std::map<std::string, double>> CoordinatorTest::four_slot_study(bool restart_before_the_last_job) {
  coordinator_.reset();
  store_.reset();
  for (const char* suffix : {"", "-wal", "-shm"}) std::filesystem::remove(path_ + suffix);
  open();
  submit(50, 30);
  worker("w", 4);
  settle(now_ += 0.01);
  std::size_t answered = 0;
  for (int round = 0; round < 9; ++round) {
    for (const std::size_t issued = out_.candidates.size(); answered < issued; ++answered) {
      const domain::Candidate& c = out_.candidates[answered];
      coordinator_->handle_report(report_for(c, 1.0 + std::sin(0.7 * c.id.trial_id) + 0.1), now_ += 0.01);
    }
    if (round == 8 && restart_before_the_last_job) {
      open();  // kill -9: the store is all that is left
      coordinator_->resume_from_store(now_);
      answered = 0;
      worker("w", 4);
    }
    settle(now_ += 0.01);
  }
  std::vector<std::map<std::string, double>> last;
  for (std::size_t i = answered; i < out_.candidates.size(); ++i) {
    last.push_back(out_.candidates[i].parameters);
  }
  return last;
}

TEST_F(CoordinatorTest, ReportsCountedButNotYetToldWaitForOneModelJobAfterARestartAsTheyWouldHave) {
  // Restarted with 4 reports counted after the last saved model state, the service must not tell them one
  // refit each while it reopens the store (at 1000 observations that kept it from serving for 7-9 s, and
  // four fits propose other points than one): they wait for the study's next model job, which tells them
  // in one batch as the uninterrupted run's job did, and the next candidates are the same to the last bit.
  const auto uninterrupted = four_slot_study(false);
  const auto restarted = four_slot_study(true);
  ASSERT_EQ(uninterrupted.size(), 4);
  EXPECT_EQ(restarted, uninterrupted);
}

TEST_F(CoordinatorTest, ARestartProposesExactlyWhatTheUninterruptedRunWould) {
  // 30 random points, then model proposals; restarted after 36 reports (6 model fits in). Every candidate
  // issued after the restart equals the uninterrupted run's, to the last bit: the optimizer is restored
  // from the saved model state and holds each stored observation exactly once.
  const auto uninterrupted = one_slot_study(42, 0);
  const auto restarted = one_slot_study(42, 36);
  ASSERT_EQ(restarted.size(), 7);
  for (std::size_t i = 0; i < restarted.size(); ++i) EXPECT_EQ(restarted[i], uninterrupted[36 + i]) << "candidate " << 36 + i;
}

TEST_F(CoordinatorTest, AFallModelStudyLearnsFromReportedFallsAndRestartsExactly) {
  // Every 4th trial falls. With fall_model the falls reach the optimizer (its proposals differ from the
  // same study without the model), from live reports and from the store after a restart alike.
  fall_every_ = 4;
  const auto without = one_slot_study(42, 0);
  extra_study_yaml_ = "fall_model: true\n";
  const auto uninterrupted = one_slot_study(42, 0);
  const auto restarted = one_slot_study(42, 36);
  EXPECT_NE(std::vector(uninterrupted.begin() + 31, uninterrupted.end()), std::vector(without.begin() + 31, without.end()));
  ASSERT_EQ(restarted.size(), 7);
  for (std::size_t i = 0; i < restarted.size(); ++i) EXPECT_EQ(restarted[i], uninterrupted[36 + i]) << "candidate " << 36 + i;
}

TEST_F(CoordinatorTest, AStudyWithNoSimulationWorkerOnTheDomainSaysSoUntilOneJoins) {
  const int id = submit(4, 2);
  settle(now_ += 0.1);
  EXPECT_EQ(out_.states.back().study_id, id);
  EXPECT_EQ(out_.states.back().message, "waiting for simulation workers: none on this domain");
  worker("a", 2);
  settle(now_ += 0.1);
  EXPECT_EQ(out_.states.back().message, "");  // it runs now
  EXPECT_FALSE(out_.candidates.empty());
}

TEST_F(CoordinatorTest, ASubmitResolvedOnAModelThreadIsAnsweredOnceWhenResolvedAndTheStudyRuns) {
  model_threads_ = 2;
  resolve_off_thread_ = true;
  open();
  worker("a", 2);
  domain::StudyCommand c = submit_command("name: t\nbudget: 6\ninitial_points: 3\nrollout: {entrain_s: 1, eval_s: 1}\n", ++correlation_);
  coordinator_->handle_command(c, now_);
  coordinator_->handle_command(c, now_);  // re-sent while its spec resolves
  // The event thread went on: nothing is stored or answered until the resolved spec is applied on it.
  EXPECT_TRUE(out_.replies.empty());
  EXPECT_EQ(coordinator_->studies(), 0);
  settle(now_ += 0.01);
  ASSERT_EQ(out_.replies.size(), 1u);  // one answer for the command sent twice
  EXPECT_TRUE(out_.replies[0].ok) << out_.replies[0].message;
  EXPECT_EQ(coordinator_->studies(), 1);
  coordinator_->handle_command(c, now_);  // re-sent after: answered from the cache, not a second study
  ASSERT_EQ(out_.replies.size(), 2u);
  EXPECT_EQ(out_.replies[1].study_id, out_.replies[0].study_id);
  EXPECT_EQ(coordinator_->studies(), 1);

  domain::StudyCommand bad = c;
  bad.correlation_id = ++correlation_;
  bad.source_name = "bad.yaml";
  bad.study_yaml = "name: t\nbudget: 6\nno_such_key: 1\n";
  coordinator_->handle_command(bad, now_);
  settle(now_ += 0.01);
  ASSERT_EQ(out_.replies.size(), 3u);
  EXPECT_FALSE(out_.replies[2].ok);
  EXPECT_NE(out_.replies[2].message.find("bad.yaml:3"), std::string::npos) << out_.replies[2].message;
  EXPECT_EQ(coordinator_->studies(), 1);

  for (int round = 0; round < 50 && out_.states.back().status != domain::StudyStatus::kDone; ++round) {
    answer_all();
    settle(now_ += 0.1);
  }
  EXPECT_EQ(out_.states.back().status, domain::StudyStatus::kDone);
  EXPECT_EQ(out_.states.back().completed, 6);
}

TEST_F(CoordinatorTest, WithModelThreadsAOneSlotStudyProposesTheSameSequenceAndRestartsExactly) {
  // Model jobs on threads: tells are applied in report order before the study's next ask, so one worker
  // with one slot gets the same candidates as with inline model work, restarts included.
  const auto inline_run = one_slot_study(42, 0);
  model_threads_ = 2;
  const auto threaded = one_slot_study(42, 0);
  EXPECT_EQ(threaded, inline_run);
  const auto restarted = one_slot_study(42, 36);
  ASSERT_EQ(restarted.size(), 7);
  for (std::size_t i = 0; i < restarted.size(); ++i) EXPECT_EQ(restarted[i], inline_run[36 + i]) << "candidate " << 36 + i;
}

TEST_F(CoordinatorTest, WhileAModelJobRunsHeartbeatsCommandsAndReportsAreServed) {
  // A study's model job is held on its thread (as a slow GP fit would be). Meanwhile the event thread
  // answers a command, drops a silent worker on time and counts reports; the job's points are issued
  // once it finishes.
  model_threads_ = 1;
  std::promise<void> release;
  std::shared_future<void> released = release.get_future().share();
  model_job_hook_ = [released](int) { released.wait(); };
  open();
  const int id = submit(20, 3);
  worker("a", 2);
  worker("b", 1);
  coordinator_->tick(now_ += 0.02);
  EXPECT_EQ(coordinator_->model_jobs_outstanding(), 1);
  EXPECT_TRUE(out_.candidates.empty());  // the asked points are not there yet

  domain::StudyCommand pause;
  pause.correlation_id = 77;
  pause.client_id = "test";
  pause.kind = domain::CommandKind::kPause;
  pause.study_id = static_cast<std::uint32_t>(id + 1);
  coordinator_->handle_command(pause, now_);
  ASSERT_EQ(out_.replies.size(), 2);  // the submit's and this one, while the job is held
  now_ += 3.0;  // b silent for 3 s > 2.5 s; a keeps announcing
  worker("a", 2);
  coordinator_->tick(now_);
  EXPECT_EQ(coordinator_->live_workers(), 1);
  EXPECT_EQ(coordinator_->model_jobs_outstanding(), 1);

  release.set_value();
  worker("a", 2);
  settle(now_ += 0.02);
  ASSERT_EQ(out_.candidates.size(), 2);  // a's two slots
  for (const auto& c : out_.candidates) EXPECT_EQ(c.worker_id, "a");
  answer_all();
  EXPECT_EQ(out_.trials.size(), 2);
}

TEST_F(CoordinatorTest, ReportsThatArriveWhileTheModelIsBusyAreFittedOnceTogether) {
  // One hyperparameter fit per batch: three reports counted while the study's job is held are told to
  // the optimizer together by its next job, with one fit (the saved model state counts the fits).
  model_threads_ = 1;
  std::promise<void> gate;
  std::shared_future<void> released = gate.get_future().share();
  auto hold = std::make_shared<std::atomic<bool>>(false);
  model_job_hook_ = [hold, released](int) {
    if (hold->load()) released.wait();
  };
  open();
  const int id = submit(30, 4);
  worker("a", 4);
  settle(now_ += 0.02);
  ASSERT_EQ(out_.candidates.size(), 4);
  answer_all();  // the initial design: the next job fits the model for the first time
  settle(now_ += 0.02);
  const int fits_before = store_->load(id)->model_state.at("fits").get<int>();
  EXPECT_EQ(fits_before, 1);
  ASSERT_EQ(out_.candidates.size(), 8);
  hold->store(true);
  coordinator_->handle_report(report_for(out_.candidates[4], 0.5), now_);
  coordinator_->tick(now_ += 0.02);  // a job tells this report (one fit) and is held
  EXPECT_EQ(coordinator_->model_jobs_outstanding(), 1);
  for (std::size_t i = 5; i < 8; ++i) coordinator_->handle_report(report_for(out_.candidates[i], 0.4 + 0.01 * i), now_);
  coordinator_->tick(now_ += 0.02);  // the study's job is busy: the three reports wait for the next one
  EXPECT_EQ(coordinator_->model_jobs_outstanding(), 1);
  hold->store(false);
  gate.set_value();
  settle(now_ += 0.02);
  const auto state = store_->load(id)->model_state;
  EXPECT_EQ(state.at("observations").get<int>(), 8);
  EXPECT_EQ(state.at("fits").get<int>(), fits_before + 2);  // one for the first report, one for the three
}

TEST_F(CoordinatorTest, AFinishedStudysTrialRecordsLeaveTheTopicAfterTheGraceAndAreNotRepublished) {
  // Memory stays flat over a long run: a finished study's records leave the DDS writer once clients
  // following it live have had them (30 s), and a restart does not publish them again (the store has them).
  const int done = submit(4, 4);
  const int open_one = submit(50, 50);
  worker("a", 4);
  coordinator_->tick(now_ += 0.1);
  answer_all();  // the first study's four trials
  coordinator_->tick(now_ += 0.1);
  answer_all();  // four of the second's
  ASSERT_EQ(store_->load(done)->state, "done");
  coordinator_->tick(now_ += 29.0);
  EXPECT_TRUE(out_.retired_trials.empty()) << "retired before the grace period was over";
  coordinator_->tick(now_ += 2.0);
  ASSERT_EQ(out_.retired_trials.size(), 4);
  for (const auto& t : out_.retired_trials) EXPECT_EQ(t.study_id, done);
  coordinator_->tick(now_ += 60.0);
  EXPECT_EQ(out_.retired_trials.size(), 4);  // once, and never the open study's

  open();
  coordinator_->resume_from_store(now_);
  for (const auto& t : out_.trials) EXPECT_EQ(t.study_id, open_one);
  EXPECT_EQ(out_.trials.size(), 4);  // the open study's counted trials only
  coordinator_->tick(now_ += 0.1);
  bool finished_state_published = false;  // its state (with the recommendation) is still served
  for (const auto& st : out_.states) finished_state_published |= st.study_id == done && st.has_recommendation;
  EXPECT_TRUE(finished_state_published);
}

TEST_F(CoordinatorTest, CandidatesCarryTheStoresIdentityAndReportsForAnotherStoreAreIgnored) {
  // Study and trial ids are only unique within a store: a report carrying another store's id (another
  // optimizer on the domain) is ignored, not counted against study 1 of this store.
  const int id = submit(6, 6);
  worker("a", 2);
  coordinator_->tick(now_ += 0.1);
  ASSERT_EQ(out_.candidates.size(), 2);
  const std::uint64_t mine = store_->store_id();
  EXPECT_NE(mine, 0u);
  for (const auto& c : out_.candidates) EXPECT_EQ(c.id.store_id, mine);
  domain::RolloutReport foreign = report_for(out_.candidates[0], 0.1);
  foreign.id.store_id = mine ^ 0x5a5a5a5a5a5a5a5aull;
  coordinator_->handle_report(foreign, now_);
  EXPECT_EQ(out_.trials.size(), 0);
  EXPECT_EQ(coordinator_->foreign_reports(), 1u);
  domain::RolloutReport own = report_for(out_.candidates[0], 0.2);
  own.id.store_id = mine;
  coordinator_->handle_report(own, now_);
  ASSERT_EQ(out_.trials.size(), 1);
  EXPECT_DOUBLE_EQ(out_.trials[0].report.summary.cost, 0.2);
  // The identity survives a restart; a new store gets another one.
  open();
  EXPECT_EQ(store_->store_id(), mine);
  EXPECT_EQ(store_->load(id)->trials.size(), 2);
  const std::string other_path = path_ + "-other.db";
  {
    study::StudyStore other(other_path);
    EXPECT_NE(other.store_id(), mine);
    EXPECT_NE(other.store_id(), 0u);
  }
  for (const char* suffix : {"", "-wal", "-shm"}) std::filesystem::remove(other_path + suffix);
}

TEST_F(CoordinatorTest, AStudyThatCannotBeReopenedIsMarkedFailedAndTheOthersAreServed) {
  const int good = submit(5, 5);
  const int bad = submit(5, 5);
  worker("w", 2);
  coordinator_->tick(now_ += 0.1);
  answer_all();
  coordinator_->tick(now_ += 0.1);
  store_->save_model_state(bad, {{"observations", 1}});  // a state with missing fields cannot be restored
  coordinator_.reset();
  // A model state that cannot be restored falls back to replaying (logged); a study with a corrupt row
  // cannot be reopened at all, but the store's other studies are served.
  {
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open(path_.c_str(), &db), SQLITE_OK);
    const std::string sql = "UPDATE trials SET x_json = 'not json' WHERE study_id = " + std::to_string(bad) +
                            " AND trial_id = 0";
    ASSERT_EQ(sqlite3_exec(db, sql.c_str(), nullptr, nullptr, nullptr), SQLITE_OK);
    sqlite3_close(db);
  }
  open();
  coordinator_->resume_from_store(now_);
  EXPECT_EQ(coordinator_->studies(), 1);
  EXPECT_EQ(store_->load(bad)->state, "failed");
  EXPECT_NE(store_->load(bad)->message.find("cannot be reopened"), std::string::npos) << store_->load(bad)->message;
  worker("w", 2);
  answered_ = 0;
  for (int round = 0; round < 20 && !coordinator_->idle(); ++round) {
    coordinator_->tick(now_ += 0.1);
    answer_all();
  }
  EXPECT_EQ(store_->load(good)->state, "done");
}

TEST_F(CoordinatorTest, SteppingTheWallClockNeitherDropsWorkersNorFiresLeases) {
  const int id = submit(4, 4);
  worker("a", 2);
  coordinator_->tick(now_ += 0.1);
  ASSERT_EQ(out_.candidates.size(), 2);
  for (const double step : {3600.0, -7200.0}) {  // NTP or a user sets the clock an hour ahead, two back
    wall_ += step;
    worker("a", 2);
    coordinator_->tick(now_ += 0.5);  // half a second of monotonic time: nothing is due
    EXPECT_EQ(out_.candidates.size(), 2) << "a re-issue after a wall-clock step of " << step << " s";
    EXPECT_EQ(out_.states.back().workers, 1);
  }
  answer_all();
  const auto s = store_->load(id);
  ASSERT_TRUE(s);
  for (const auto& t : s->trials) {
    if (t.status == study::TrialStatus::kDone) {
      EXPECT_DOUBLE_EQ(t.reported_at_s, wall_);  // Unix time in the store
    }
  }
}

TEST_F(CoordinatorTest, AHugeWorkerIsFilledOverSeveralTicksAndAnotherWorkersTimeoutIsNotDelayed) {
  submit(2000, 2000);
  worker("huge", 512);
  worker("small", 1);
  coordinator_->tick(now_ += 0.02);
  const std::size_t first_tick = out_.candidates.size();
  // Both caps hold: the points asked for (max_new_candidates_per_tick) and the DDS writes (max_issues_per_tick).
  const int cap = std::min(CoordinatorOptions{}.max_new_candidates_per_tick, CoordinatorOptions{}.max_issues_per_tick);
  EXPECT_EQ(first_tick, static_cast<std::size_t>(cap));
  // "small" falls silent; "huge" keeps announcing. Ticks go on filling "huge" meanwhile, and "small" is
  // dropped as soon as its timeout has passed, not after all 513 slots are filled.
  bool small_dropped = false;
  int ticks = 0;
  for (; ticks < 200 && !small_dropped; ++ticks) {
    const std::size_t before = out_.candidates.size();
    worker("huge", 512);
    coordinator_->tick(now_ += 0.02);
    EXPECT_LE(out_.candidates.size() - before, static_cast<std::size_t>(cap)) << "tick " << ticks;  // re-issues included
    small_dropped = out_.states.back().workers == 1u;
  }
  EXPECT_TRUE(small_dropped);
  EXPECT_LE(ticks * 0.02, CoordinatorOptions{}.worker_timeout_s + 0.1);
}

TEST_F(CoordinatorTest, ALargeFillIsSpreadOverTicksWithoutAskingForMorePointsThanThereAreSlots) {
  const int id = submit(150, 15);
  worker("big", 64);
  // No report comes back: the 64 slots are filled 16 per tick, and the points proposed for them (the 15
  // random ones, then the model's with lies) never outnumber the slots.
  for (int tick = 0; tick < 10; ++tick) {
    worker("big", 64);
    const std::size_t before = out_.candidates.size();
    coordinator_->tick(now_ += 0.02);
    EXPECT_LE(out_.candidates.size() - before, static_cast<std::size_t>(CoordinatorOptions{}.max_issues_per_tick));
    EXPECT_LE(static_cast<int>(out_.candidates.size()) + coordinator_->points_waiting(id), 64) << "tick " << tick;
  }
  EXPECT_EQ(out_.candidates.size(), 64);
  EXPECT_EQ(coordinator_->points_waiting(id), 0);
}

TEST_F(CoordinatorTest, TheStudyStateCarriesTheModelsRecommendation) {
  one_slot_study(40, 0);  // 30 random points, then 10 model proposals
  const domain::StudyState& st = out_.states.back();
  ASSERT_TRUE(st.has_recommendation);
  const auto stored = store_->load(st.study_id);
  ASSERT_TRUE(stored);
  const auto& trial = stored->trials.at(st.recommendation.trial);
  EXPECT_EQ(trial.status, study::TrialStatus::kDone);
  // Its parameters are that trial's, and its predicted cost is within the observed range.
  const auto& named = st.recommendation.params;
  EXPECT_FALSE(named.empty());
  double lo = INFINITY, hi = -INFINITY;
  for (const auto& t : stored->trials) {
    if (t.status == study::TrialStatus::kDone) lo = std::min(lo, t.cost), hi = std::max(hi, t.cost);
  }
  EXPECT_GE(st.recommendation.predicted_cost, lo - 0.5);
  EXPECT_LE(st.recommendation.predicted_cost, hi);
}

TEST_F(CoordinatorTest, BadCommandsAreRefusedWithTheReason) {
  domain::StudyCommand c;
  c.kind = domain::CommandKind::kSubmit;
  c.study_yaml = "name: t\nbudget: 0\n";
  c.source_name = "bad.yaml";
  coordinator_->handle_command(c, now_);
  ASSERT_EQ(out_.replies.size(), 1);
  EXPECT_FALSE(out_.replies[0].ok);
  EXPECT_NE(out_.replies[0].message.find("bad.yaml:2"), std::string::npos) << out_.replies[0].message;
  c.kind = domain::CommandKind::kPause;
  c.correlation_id = 2;
  c.study_id = 5;
  coordinator_->handle_command(c, now_);
  EXPECT_FALSE(out_.replies[1].ok);
  EXPECT_EQ(coordinator_->studies(), 0);
}

TEST_F(CoordinatorTest, AResentCommandGetsTheSameReplyNotASecondStudy) {
  domain::StudyCommand c;
  c.correlation_id = 7;
  c.client_id = "client-a";
  c.kind = domain::CommandKind::kSubmit;
  c.study_yaml = "name: once\n";
  coordinator_->handle_command(c, now_);
  coordinator_->handle_command(c, now_ + 2.0);  // the client did not see the reply and sent it again
  ASSERT_EQ(out_.replies.size(), 2);
  EXPECT_EQ(coordinator_->studies(), 1);
  EXPECT_EQ(out_.replies[0].study_id, out_.replies[1].study_id);
  EXPECT_TRUE(out_.replies[1].ok);
  c.client_id = "client-b";  // same correlation id from another client: a different command
  coordinator_->handle_command(c, now_ + 3.0);
  EXPECT_EQ(coordinator_->studies(), 2);
}

TEST_F(CoordinatorTest, PausedStudyGetsNoNewCandidates) {
  const int id = submit(10, 10);
  domain::StudyCommand pause;
  pause.correlation_id = 1001;
  pause.kind = domain::CommandKind::kPause;
  pause.study_id = static_cast<std::uint32_t>(id);
  coordinator_->handle_command(pause, now_);
  EXPECT_TRUE(out_.replies.back().ok);
  worker("a", 4);
  coordinator_->tick(now_);
  EXPECT_TRUE(out_.candidates.empty());
  pause.kind = domain::CommandKind::kResume;
  pause.correlation_id = 1002;
  coordinator_->handle_command(pause, now_);
  coordinator_->tick(now_ += 0.1);
  EXPECT_EQ(out_.candidates.size(), 4);
}

TEST_F(CoordinatorTest, SeveralStudiesShareTheWorkersAndAllFinish) {
  const int first = submit(6, 6);
  const int second = submit(6, 6);
  worker("a", 1);
  std::set<std::uint32_t> served_early;
  for (int round = 0; round < 40 && !coordinator_->idle(); ++round) {
    coordinator_->tick(now_ += 0.1);
    if (round < 4 && !out_.candidates.empty()) served_early.insert(out_.candidates.back().id.study_id);
    answer_all();
  }
  EXPECT_EQ(served_early.size(), 2) << "round-robin should serve both studies from the start";
  EXPECT_EQ(store_->load(first)->state, "done");
  EXPECT_EQ(store_->load(second)->state, "done");
  EXPECT_EQ(out_.trials.size(), 12);
}

// Done trials as another connection sees them (what a restarted optimizer would find).
int done_trials_seen_from_outside(const std::string& path) {
  sqlite3* db = nullptr;
  EXPECT_EQ(sqlite3_open_v2(path.c_str(), &db, SQLITE_OPEN_READONLY, nullptr), SQLITE_OK);
  sqlite3_stmt* st = nullptr;
  sqlite3_prepare_v2(db, "SELECT count(*) FROM trials WHERE status = 'done'", -1, &st, nullptr);
  int n = -1;
  if (sqlite3_step(st) == SQLITE_ROW) n = sqlite3_column_int(st, 0);
  sqlite3_finalize(st);
  sqlite3_close(db);
  return n;
}

TEST_F(CoordinatorTest, ABurstOfReportsCommitsAtomicallyAndIsAcknowledgedOnlyAfterItsCommit) {
  defer_ = true;
  open();
  const int id = submit(12, 12);
  worker("a", 4);
  coordinator_->tick(now_);
  ASSERT_EQ(out_.candidates.size(), 4);
  {
    // The service's loop: the burst and the tick in one transaction, what they publish held. No commit:
    // the process dies (kill -9) before it.
    study::StudyStore::Batch batch(*store_);
    deferred_->hold();
    answer_all();
    coordinator_->tick(now_ += 0.1);  // issues 4 more (store first, inside the batch: a savepoint)
    EXPECT_TRUE(out_.retired.empty()) << "a report was acknowledged before its commit";
    EXPECT_TRUE(out_.trials.empty());
    EXPECT_EQ(out_.candidates.size(), 4) << "a candidate was published before its commit";
    EXPECT_GT(deferred_->held(), 8u);
    EXPECT_EQ(done_trials_seen_from_outside(path_), 0);
    deferred_->discard();
  }
  EXPECT_EQ(done_trials_seen_from_outside(path_), 0);
  open();  // the restart: none of the burst happened, the 4 candidates are still out
  coordinator_->resume_from_store(now_);
  auto stored = store_->load(id);
  ASSERT_TRUE(stored);
  EXPECT_EQ(stored->trials.size(), 4);
  for (const auto& t : stored->trials) EXPECT_EQ(t.status, study::TrialStatus::kInFlight);

  // The same burst, committed: all of it at once, then published.
  worker("a", 4);
  out_ = RecordingOutbox{};
  answered_ = 0;
  coordinator_->tick(now_ += 0.1);  // re-issues the 4
  ASSERT_EQ(out_.candidates.size(), 4);
  {
    study::StudyStore::Batch batch(*store_);
    deferred_->hold();
    answer_all();
    EXPECT_TRUE(out_.retired.empty());
    batch.commit();
    EXPECT_EQ(done_trials_seen_from_outside(path_), 4);
    deferred_->release();
  }
  EXPECT_EQ(out_.retired.size(), 4);
  EXPECT_EQ(out_.trials.size(), 4);
  EXPECT_THROW(
      {
        study::StudyStore::Batch a(*store_);
        study::StudyStore::Batch b(*store_);
      },
      std::logic_error);
  EXPECT_FALSE(store_->in_batch());
}

std::map<int, std::map<std::string, double>> two_worker_study(CoordinatorTest& t, int lockstep, bool newest_first,
                                                              int restart_at_step) {
  return t.run_two_worker_study(lockstep, newest_first, restart_at_step);
}

}  // namespace
}  // namespace cpgmatch::service

namespace cpgmatch::service {
namespace {

TEST_F(CoordinatorTest, ARefusedCandidateIsReissuedNeverSpentAndTheRefusingWorkerIsLeftAloneForAWhile) {
  const int id = submit(2, 2);
  worker("a", 1);
  coordinator_->tick(now_);
  ASSERT_EQ(out_.candidates.size(), 1);
  const domain::Candidate first = out_.candidates.back();
  coordinator_->handle_report(unspent_report(first, domain::Outcome::kRefused, "refused: emergency stop latched: test"), now_);
  // Within the backoff the refusing worker gets nothing of this study; a second worker takes the trial.
  coordinator_->tick(now_ += 0.1);
  EXPECT_EQ(out_.candidates.size(), 1);
  worker("b", 1);
  coordinator_->tick(now_ += 0.1);
  ASSERT_EQ(out_.candidates.size(), 2);
  const domain::Candidate again = out_.candidates.back();
  EXPECT_EQ(again.worker_id, "b");
  EXPECT_EQ(again.id.trial_id, first.id.trial_id);
  EXPECT_EQ(again.id.attempt, first.id.attempt + 1);
  EXPECT_EQ(again.parameters, first.parameters);
  // Nothing counted, nothing failed; the refusal is on record.
  EXPECT_EQ(out_.states.empty() ? 0u : out_.states.back().completed, 0);
  const auto attempts = store_->unspent_attempts(id);
  ASSERT_EQ(attempts.size(), 1);
  EXPECT_EQ(attempts[0].outcome, "refused");
  // After the backoff "a" serves the study again; the study ends with both trials counted, none failed.
  now_ += 3.0;
  worker("a", 1);  // heartbeats meanwhile
  worker("b", 1);
  coordinator_->tick(now_);
  answered_ = 1;  // the refused candidate was answered above
  for (int round = 0; round < 10 && !coordinator_->idle(); ++round) {
    answer_all();
    coordinator_->tick(now_ += 0.2);
  }
  EXPECT_EQ(store_->load(id)->state, "done");
  EXPECT_EQ(out_.states.back().completed, 2);
  EXPECT_EQ(out_.states.back().failed, 0);
  EXPECT_EQ(sent_to("a").size(), 2) << "worker a never served the study again after its backoff";
}

TEST_F(CoordinatorTest, PlantFaultsAreRetriedThenSpentAsAFailureTheModelNeverSees) {
  const int id = submit(3, 3);
  worker("robot", 1);
  coordinator_->tick(now_);
  const int trial = out_.candidates.back().id.trial_id;
  // Faults 1 and 2: re-issued each time, nothing counted.
  for (int fault = 1; fault <= 2; ++fault) {
    const domain::Candidate c = out_.candidates.back();
    ASSERT_EQ(c.id.trial_id, trial);
    ASSERT_EQ(c.id.attempt, fault - 1);
    // From a robot: its faults may not repeat (a simulation's divergence would, and is spent at once).
    domain::RolloutReport r = unspent_report(c, fault == 1 ? domain::Outcome::kPlantFault : domain::Outcome::kDiverged, "watchdog");
    r.worker_kind = domain::WorkerKind::kHardware;
    coordinator_->handle_report(r, now_);
    coordinator_->tick(now_ += 0.1);
    EXPECT_EQ(out_.candidates.back().id.attempt, fault) << "fault " << fault << " not re-issued";
  }
  EXPECT_TRUE(out_.trials.empty());
  // A stale report of an older attempt changes nothing: no re-issue, no fault counted.
  domain::Candidate stale = out_.candidates.back();
  stale.id.attempt = 0;
  const std::size_t sent_before = out_.candidates.size();
  coordinator_->handle_report(unspent_report(stale, domain::Outcome::kPlantFault, "late"), now_);
  coordinator_->tick(now_ += 0.1);
  EXPECT_EQ(out_.candidates.size(), sent_before);
  EXPECT_EQ(store_->unspent_attempts(id).size(), 2);
  EXPECT_EQ(store_->load(id)->trials.at(static_cast<std::size_t>(trial)).faults, 2);
  // The third fault reaches the bound (3): spent as a failed trial, its report the fault.
  coordinator_->handle_report(unspent_report(out_.candidates.back(), domain::Outcome::kPlantFault, "watchdog"), now_);
  ASSERT_EQ(out_.trials.size(), 1);
  EXPECT_EQ(out_.trials.back().report.outcome, domain::Outcome::kPlantFault);
  answered_ = out_.candidates.size();
  for (int round = 0; round < 10 && !coordinator_->idle(); ++round) {
    coordinator_->tick(now_ += 0.2);
    answer_all();
  }
  const auto done = store_->load(id);
  EXPECT_EQ(done->state, "done");
  EXPECT_EQ(out_.states.back().failed, 1);
  // The model was told the faulted trial as excluded: after a restart it is replayed the same way.
  open();
  coordinator_->resume_from_store(now_);
  EXPECT_TRUE(warnings_.empty() || warnings_.back().find("cannot be reopened") == std::string::npos);
}

TEST_F(CoordinatorTest, ASimulationThatDivergedIsSpentAtOnceItWouldDivergeAgain) {
  submit(2, 2);
  worker("a", 1);
  coordinator_->tick(now_);
  domain::RolloutReport r = unspent_report(out_.candidates.back(), domain::Outcome::kDiverged, "state diverged");
  r.worker_kind = domain::WorkerKind::kSimulation;
  coordinator_->handle_report(r, now_);
  ASSERT_EQ(out_.trials.size(), 1);  // spent: a trial record, no re-issue of the same point
  EXPECT_EQ(out_.trials.back().report.outcome, domain::Outcome::kDiverged);
  coordinator_->tick(now_ += 0.1);
  EXPECT_EQ(out_.candidates.back().id.trial_id, 1);  // the next trial, not the diverged one again
}

TEST_F(CoordinatorTest, AStudyWaitingForAnEmergencyStoppedRobotSaysSoAndIssuesItNothing) {
  extra_study_yaml_ = "explore_on: hardware\n";
  submit(2, 2);
  domain::WorkerAnnouncement w;
  w.worker_id = "morti";
  w.worker_key = domain::worker_key("morti");
  w.slots = 1;
  w.kind = domain::WorkerKind::kHardware;
  w.accepting = false;
  w.status = "emergency-stopped (operator pressed stop)";
  coordinator_->handle_worker(w, now_);
  coordinator_->tick(now_ += 0.2);
  EXPECT_TRUE(out_.candidates.empty());
  ASSERT_FALSE(out_.states.empty());
  EXPECT_EQ(out_.states.back().message, "waiting: robot morti emergency-stopped (operator pressed stop)");
  // Released: it accepts again, the study goes on and the message clears.
  w.accepting = true;
  w.status = "";
  coordinator_->handle_worker(w, now_);
  coordinator_->tick(now_ += 0.2);
  EXPECT_EQ(out_.candidates.size(), 1);
  coordinator_->tick(now_ += 0.2);
  EXPECT_EQ(out_.states.back().message, "");
}

TEST_F(CoordinatorTest, CandidatesCarryTheStudysSpecAndItIsPublishedBeforeThem) {
  struct SpecRecorder : RecordingOutbox {
    std::vector<domain::SpecPublication> specs;
    void publish_spec(const domain::SpecPublication& s) override { specs.push_back(s); }
  };
  SpecRecorder out;
  CoordinatorOptions options;
  options.wall_clock_s = [] { return 1.7e9; };
  Coordinator c(*store_, out, options, [](const std::string&) {}, [](const std::string&) {});
  domain::StudyCommand cmd = submit_command("name: s\nbudget: 2\ninitial_points: 2\nmodel: {knee_spring: {stiffness_nm_per_rad: 20}}\n", 1);
  c.handle_command(cmd, now_);
  ASSERT_TRUE(out.replies.back().ok) << out.replies.back().message;
  ASSERT_EQ(out.specs.size(), 1);
  const auto stored = store_->load(out.replies.back().study_id);
  EXPECT_EQ(out.specs[0].sha256, stored->spec.sha256);
  EXPECT_EQ(out.specs[0].json, stored->spec.json);
  EXPECT_EQ(stored->spec.origin, "submitted");
  domain::WorkerAnnouncement w;
  w.worker_id = "a";
  w.worker_key = domain::worker_key("a");
  w.slots = 2;
  w.accepting = true;
  c.handle_worker(w, now_);
  c.tick(now_);
  ASSERT_EQ(out.candidates.size(), 2);
  for (const auto& cand : out.candidates) EXPECT_EQ(cand.spec_key, out.specs[0].key);
}

}  // namespace
}  // namespace cpgmatch::service

namespace cpgmatch::service {
namespace {

TEST_F(CoordinatorTest, AnOversizedStudyFileIsRefusedBeforeAnythingParsesIt) {
  // 700k keys, about 12 MB: what once took the service to 800 MB.
  std::string huge = "name: huge\n";
  huge.reserve(12'000'000);
  for (int i = 0; huge.size() < 12'000'000; ++i) huge += "k" + std::to_string(i) + ": 1\n";
  domain::StudyCommand c = submit_command(huge, 1);
  c.source_name = "huge.yaml";
  coordinator_->handle_command(c, now_);
  ASSERT_EQ(out_.replies.size(), 1);
  EXPECT_FALSE(out_.replies[0].ok);
  const std::string message = out_.replies[0].message;
  EXPECT_NE(message.find("huge.yaml"), std::string::npos) << message;
  EXPECT_NE(message.find(std::to_string(study::kMaxStudyFileBytes)), std::string::npos) << message;
  EXPECT_EQ(coordinator_->studies(), 0);
  // Just under the limit is still a study file like any other (here a bad one, refused by its parser).
  c.correlation_id = 2;
  c.study_yaml = "name: fine\nbudget: 0\n" + std::string(1000, '#');
  coordinator_->handle_command(c, now_);
  EXPECT_NE(out_.replies[1].message.find("budget"), std::string::npos);
}

TEST_F(CoordinatorTest, AStudysElapsedTimeIsNeverNegativeAfterTheWallClockIsSteppedBack) {
  submit(4, 4);
  worker("a", 1);
  coordinator_->tick(now_ += 0.2);
  wall_ += 30.0;
  answer_all();  // a report: the state changes and is published again
  coordinator_->tick(now_ += 0.2);
  ASSERT_FALSE(out_.states.empty());
  EXPECT_DOUBLE_EQ(out_.states.back().elapsed_s, 30.0);  // the study's age on the (fake) wall clock
  const std::size_t published = out_.states.size();
  wall_ -= 3600.0;  // NTP or a user sets the clock an hour back, to before the study was created
  answer_all();
  coordinator_->tick(now_ += 0.2);
  ASSERT_GT(out_.states.size(), published);
  EXPECT_EQ(out_.states.back().elapsed_s, 0.0);
}

}  // namespace
}  // namespace cpgmatch::service
