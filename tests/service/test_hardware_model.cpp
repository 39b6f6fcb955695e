// One model over simulation and hardware (issue 23): `hardware: {strategy: transfer | multi_fidelity}` studies
// driven through the Coordinator with a hand-made simulation worker and robot. The simulation explores its
// budget; the study's bo::HardwareOptimizer learns from both sources, proposes the robot's rollouts and gives
// the study's answer; a restart in the middle changes nothing.
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <mutex>
#include <set>
#include <thread>
#include <vector>

#include <fmt/format.h>

#include "cpgmatch/bo/model_state_json.hpp"
#include "cpgmatch/params.hpp"
#include "cpgmatch/rollout.hpp"
#include "cpgmatch/service/coordinator.hpp"
#include "cpgmatch/study/study_spec.hpp"
#include "coordinator_test_support.hpp"

namespace cpgmatch::service {
namespace {

using test_support::RecordingOutbox;
using test_support::study_error;

// Two parameters, so that a hardware ask takes milliseconds; 12 simulated rollouts, 6 of them the initial design.
// `start_after` 6 by default here: robot rollouts interleaved with the simulation, the schedule whose restarts
// these tests exercise; empty: the study file's default (the whole simulation first).
std::string study_yaml(const std::string& strategy, int hardware_budget, const std::string& start_after = "6") {
  return "name: two-sources\nbudget: 12\ninitial_points: 6\nseed: 5\nrollout: {entrain_s: 1, eval_s: 1}\n"
         "parameters: [{name: hip_offset, low: -0.35, high: 0.35}, {name: hip_amplitude, low: 0.1, high: 0.65}]\n"
         "hardware: {strategy: " + strategy + ", budget: " + std::to_string(hardware_budget) +
         (start_after.empty() ? std::string() : ", start_after: " + start_after) + "}\n";
}

// The two sources, on the unit square: a smooth bowl in simulation; on the robot 0.8 of it plus a gap that
// grows with the hip offset, so the robot's optimum is not the simulation's. Both > 0 (log costs).
double unit(const domain::Candidate& c, const std::string& name, double low, double high) {
  return (c.parameters.at(name) - low) / (high - low);
}
double simulated_cost(const domain::Candidate& c) {
  const double u = unit(c, "hip_offset", -0.35, 0.35), v = unit(c, "hip_amplitude", 0.1, 0.65);
  return 1.0 + 4.0 * (u - 0.6) * (u - 0.6) + 4.0 * (v - 0.3) * (v - 0.3);
}
double hardware_cost(const domain::Candidate& c) {
  return 0.8 * simulated_cost(c) + 0.3 + 0.9 * unit(c, "hip_offset", -0.35, 0.35);
}

// A stored study's trials of one phase, in trial order.
std::vector<const study::StoredTrial*> phase(const study::StoredStudy& s, const std::string& p) {
  std::vector<const study::StoredTrial*> out;
  for (const auto& t : s.trials) {
    if (t.phase == p) out.push_back(&t);
  }
  return out;
}

// The hardware points of a study, in trial order.
std::vector<Eigen::VectorXd> hardware_points_of(const study::StoredStudy& s) {
  std::vector<Eigen::VectorXd> out;
  for (const auto* t : phase(s, "hardware")) out.push_back(t->x);
  return out;
}

class HardwareModelTest : public test_support::CoordinatorFixture {
 protected:
  HardwareModelTest() : CoordinatorFixture("hwmodel") {}
  CoordinatorOptions options() override {
    CoordinatorOptions o = CoordinatorFixture::options();
    o.model_threads = model_threads_;
    o.model_job_hook = [this](int) {
      std::lock_guard<std::mutex> lock(jobs_mutex_);
      job_threads_.insert(std::this_thread::get_id());
      ++model_jobs_;
    };
    return o;
  }
  void heartbeat() {
    worker("sim", 1, domain::WorkerKind::kSimulation);
    if (robot_) worker("robot", 1, domain::WorkerKind::kHardware);
  }
  // The report a worker would send: the source's cost; the robot falls where `robot_falls` says.
  domain::RolloutReport report_for(const domain::Candidate& c) {
    const bool hw = c.worker_id == "robot";
    domain::RolloutReport r = test_support::completed_report(
        c, hw ? hardware_cost(c) : simulated_cost(c), hw ? domain::WorkerKind::kHardware : domain::WorkerKind::kSimulation);
    if (hw && robot_falls && robot_falls(c)) {
      r.outcome = domain::Outcome::kFell;  // ok and fell follow the outcome
      r.summary.cost = 15.0;
    }
    return r;
  }
  void answer_all() {
    while (answered_ < out_.candidates.size()) {
      const domain::Candidate c = out_.candidates[answered_++];
      if (c.worker_id == "robot") {
        ++robot_candidates_;
        if (sim_reports_at_first_robot_candidate_ < 0) sim_reports_at_first_robot_candidate_ = sim_reports_;
        if (fault_first_robot_candidate_ && robot_candidates_ == 1) {
          domain::RolloutReport r = report_for(c);
          r.outcome = domain::Outcome::kPlantFault;
          r.error = "motor watchdog";
          coordinator_->handle_report(r, now_);
          continue;
        }
      } else {
        ++sim_reports_;
      }
      coordinator_->handle_report(report_for(c), now_);
    }
  }
  // Rounds of heartbeat, tick, answers. With restart_at_round >= 0 the service is killed and restarted on its
  // store in that round: after the tick with its candidates in flight (restart_in_flight), else after the answers.
  void run(int rounds, int restart_at_round = -1, bool restart_in_flight = false) {
    for (int round = 0; round < rounds; ++round) {
      heartbeat();
      settle();
      if (round == restart_at_round && restart_in_flight) restart();
      answer_all();
      if (round == restart_at_round && !restart_in_flight) restart();
    }
    heartbeat();
    settle();
  }
  // A tick; with model threads, ticks until every model job it started has finished and been applied (what
  // the service's event loop does as results arrive). Without: the tick, whose jobs run inline.
  void settle() {
    coordinator_->tick(now_ += 0.2);
    while (coordinator_->model_jobs_outstanding() > 0) {
      coordinator_->wait_for_models();
      coordinator_->tick(now_);
    }
  }
  // kill -9 and restart: the store is all that is left. Candidates still unanswered are answered by their
  // workers all the same, and those reports reach the new service (as from the workers' transient-local
  // history) before its first tick: the same events as in the uninterrupted run, in the same order.
  void restart() {
    const std::vector<domain::Candidate> unanswered(out_.candidates.begin() + static_cast<long>(answered_),
                                                    out_.candidates.end());
    open();
    coordinator_->resume_from_store(now_);
    restarted_with_hardware_done_ = hardware_done();
    restarted_with_hardware_stored_ = 0;
    for (const auto& st : store_->load_all()) restarted_with_hardware_stored_ += static_cast<int>(phase(st, "hardware").size());
    heartbeat();
    out_.candidates = unanswered;
  }
  int hardware_done() const {
    int n = 0;
    for (const auto& s : store_->load_all()) {
      for (const auto& t : s.trials) n += t.phase == "hardware" && t.status == study::TrialStatus::kDone;
    }
    return n;
  }
  // Runs a study to its end and checks what every such study must satisfy; returns the stored study.
  study::StoredStudy run_to_the_end(const std::string& strategy, int hardware_budget, int restart_at_round = -1,
                                    bool restart_in_flight = false) {
    int id = 0;
    if (enqueue_.empty()) {
      id = submit(study_yaml(strategy, hardware_budget, start_after_));
    } else {
      domain::StudyCommand c = test_support::submit_command(study_yaml(strategy, hardware_budget, start_after_), ++correlation_);
      c.enqueue = enqueue_;
      coordinator_->handle_command(c, now_);
      EXPECT_TRUE(out_.replies.back().ok) << out_.replies.back().message;
      id = static_cast<int>(out_.replies.back().study_id);
    }
    run(60, restart_at_round, restart_in_flight);
    const auto s = store_->load(id);
    if (!s) {
      ADD_FAILURE() << "no study " << id;
      return {};
    }
    EXPECT_EQ(s->state, "done") << s->message;
    auto explored = phase(*s, "exploration");
    for (const auto* t : phase(*s, study::kPhaseEnqueued)) explored.push_back(t);  // simulated trials too
    const auto hardware = phase(*s, "hardware");
    EXPECT_EQ(explored.size(), 12u);
    EXPECT_EQ(hardware.size(), static_cast<std::size_t>(hardware_budget));  // the hardware budget, not one more
    for (const auto* t : explored) EXPECT_EQ(t->worker_id, "sim") << "trial " << t->trial_id;
    for (const auto* t : hardware) {
      EXPECT_EQ(t->worker_id, "robot") << "trial " << t->trial_id;
      EXPECT_EQ(t->status, study::TrialStatus::kDone);
    }
    std::set<int> hardware_ids;
    for (const auto* t : hardware) hardware_ids.insert(t->trial_id);
    // Every candidate of a hardware trial went to the robot, and the robot got nothing else.
    for (const auto& c : out_.candidates) {
      EXPECT_EQ(hardware_ids.count(c.id.trial_id) > 0, c.worker_id == "robot") << "trial " << c.id.trial_id;
    }
    return *s;
  }

  bool robot_ = true;
  std::string start_after_ = "6";  // study_yaml's; empty: the default
  std::vector<domain::EnqueuedGait> enqueue_;  // gaits queued at submit
  int model_threads_ = 0;  // 0: model jobs inline
  std::mutex jobs_mutex_;
  std::set<std::thread::id> job_threads_;  // where model jobs ran
  int model_jobs_ = 0;
  std::function<bool(const domain::Candidate&)> robot_falls;
  bool fault_first_robot_candidate_ = false;
  int robot_candidates_ = 0, sim_reports_ = 0, sim_reports_at_first_robot_candidate_ = -1;
  int restarted_with_hardware_done_ = -1, restarted_with_hardware_stored_ = -1;
};

// The checks of a finished study's answer and its hardware model, for either strategy.
void expect_the_answer_is_the_robots(const study::StoredStudy& s, const domain::StudyState& last, int hardware_budget) {
  const auto hardware = phase(s, "hardware");
  EXPECT_EQ(last.status, domain::StudyStatus::kDone);
  EXPECT_EQ(last.budget, 12 + hardware_budget);
  EXPECT_EQ(last.completed, 12 + hardware_budget);
  // The answer is a hardware trial, the one the robot measured lowest (noise-free data), predicted near the
  // robot's cost there, not the simulation's (within 5 %: the fitted noise terms smooth a little).
  ASSERT_TRUE(last.has_recommendation);
  const study::StoredTrial* lowest = nullptr;
  for (const auto* t : hardware) {
    if (t->ok && (lowest == nullptr || t->cost < lowest->cost)) lowest = t;
  }
  ASSERT_NE(lowest, nullptr);
  std::string costs;
  for (const auto* t : hardware) costs += fmt::format(" trial {}: {:.6f}", t->trial_id, t->cost);
  EXPECT_EQ(last.recommendation.trial, lowest->trial_id) << costs << "; predicted " << last.recommendation.predicted_cost;
  EXPECT_NEAR(last.recommendation.predicted_cost, lowest->cost, 0.05 * lowest->cost);
  const double u = (lowest->x[0] + 0.35) / 0.7;
  const double simulated_there = (lowest->cost - 0.3 - 0.9 * u) / 0.8;  // hardware_cost() inverted
  EXPECT_LT(std::abs(last.recommendation.predicted_cost - lowest->cost),
            std::abs(last.recommendation.predicted_cost - simulated_there));
  // The saved hardware model holds every result of both sources.
  ASSERT_TRUE(s.hardware_model_state.is_object()) << s.hardware_model_state.dump();
  const bo::HardwareModelState state = bo::hardware_model_state_from_json(s.hardware_model_state);
  EXPECT_EQ(state.simulation_observations, 12);
  EXPECT_EQ(state.hardware_observations, hardware_budget);
  EXPECT_TRUE(state.have_hyperparameters);
}

// The first hardware trial is the transferred simulated optimum: exactly the point of a simulated trial that
// walked, none of the initial design (all told before the first hardware ask) cheaper. Every hardware trial
// keeps its safety check; after the first, against (1 + margin) times the best robot cost reported before it.
void expect_the_robot_starts_from_the_simulations_best(const study::StoredStudy& s, double margin = 0.1) {
  const auto hardware = phase(s, "hardware");
  ASSERT_FALSE(hardware.empty());
  const study::StoredTrial& first = *hardware.front();
  const study::StoredTrial* source = nullptr;
  for (const auto& t : s.trials) {
    if (t.phase != "hardware" && t.x == first.x) source = &t;
  }
  ASSERT_NE(source, nullptr) << "the first robot point is no simulated trial's point";
  EXPECT_TRUE(source->ok);
  for (const auto& t : s.trials) {
    if (t.phase == "exploration" && t.trial_id < 6 && t.ok) {
      EXPECT_LE(source->cost, t.cost) << "trial " << t.trial_id;
    }
  }
  ASSERT_TRUE(first.proposal);
  EXPECT_EQ(first.proposal->basis, "simulation_optimum");
  EXPECT_FALSE(first.proposal->cost_limit) << "no robot cost to bound the first rollout by";
  double best_robot = std::numeric_limits<double>::infinity();
  for (const auto* t : hardware) {
    ASSERT_TRUE(t->proposal) << "trial " << t->trial_id;
    if (t == &first) continue;
    const auto& p = *t->proposal;
    ASSERT_TRUE(p.cost_limit) << "trial " << t->trial_id;
    EXPECT_EQ(p.within_cost_bound, p.cost_bound <= *p.cost_limit) << "trial " << t->trial_id;
    EXPECT_TRUE(p.basis == "safe" || p.basis == "lowest_bound" || p.basis == "least_likely_to_fall") << p.basis;
    EXPECT_EQ(p.basis == "safe", p.within_cost_bound && p.within_fall_limit) << "trial " << t->trial_id;
    // The limit is never below (1 + margin) times a robot cost that walked and was reported before the
    // proposal was made (the robot runs one at a time here: every earlier hardware trial).
    best_robot = std::numeric_limits<double>::infinity();
    for (const auto* earlier : hardware) {
      const auto report = study::stored_report(*earlier);
      if (earlier->trial_id < t->trial_id && report && report->ok() && !report->fell()) {
        best_robot = std::min(best_robot, earlier->cost);
      }
    }
    if (std::isfinite(best_robot)) {
      EXPECT_NEAR(*p.cost_limit, (1.0 + margin) * best_robot, 1e-9) << "trial " << t->trial_id;
    }
  }
}

TEST_F(HardwareModelTest, AMultiFidelityStudyProposesTheRobotsRolloutsAndAnswersWithTheRobotsBest) {
  const study::StoredStudy s = run_to_the_end("multi_fidelity", 5);
  expect_the_answer_is_the_robots(s, out_.states.back(), 5);
  // Hardware proposals start once the initial design (6 simulated results) is told, not before.
  EXPECT_GE(sim_reports_at_first_robot_candidate_, 6);
  // Five different robot points (pending ones are avoided).
  std::set<std::vector<double>> points;
  for (const auto* t : phase(s, "hardware")) points.insert(std::vector<double>(t->x.data(), t->x.data() + t->x.size()));
  EXPECT_EQ(points.size(), 5u);
  EXPECT_NE(s.message.find("5 hardware rollouts (multi_fidelity)"), std::string::npos) << s.message;
  expect_the_robot_starts_from_the_simulations_best(s);
}

// The default schedule: the robot waits for the whole simulated exploration and starts from its best.
TEST_F(HardwareModelTest, ByDefaultTheRobotStartsAfterTheWholeSimulationFromItsBest) {
  start_after_.clear();
  const study::StoredStudy s = run_to_the_end("multi_fidelity", 3);
  EXPECT_EQ(sim_reports_at_first_robot_candidate_, 12) << "every simulated result before the first robot candidate";
  expect_the_robot_starts_from_the_simulations_best(s);
  // Its point: the best of all twelve simulated rollouts, not only of the initial design.
  const study::StoredTrial& first = *phase(s, "hardware").front();
  for (const auto& t : s.trials) {
    if (t.phase == "exploration" && t.ok && t.x != first.x) {
      const auto report = study::stored_report(t);
      if (report && !report->fell()) {
        for (const auto& u : s.trials) {
          if (u.phase == "exploration" && u.x == first.x) {
            EXPECT_LE(u.cost, t.cost) << "trial " << t.trial_id;
          }
        }
      }
    }
  }
}

TEST_F(HardwareModelTest, ATransferStudyLikewise) {
  const study::StoredStudy s = run_to_the_end("transfer", 4);
  expect_the_answer_is_the_robots(s, out_.states.back(), 4);
  EXPECT_GE(sim_reports_at_first_robot_candidate_, 6);
  expect_the_robot_starts_from_the_simulations_best(s);
}

TEST_F(HardwareModelTest, WithAnEnqueuedGaitTheRobotStartsFromItAlsoAcrossARestart) {
  // A queued known gait, not the simulation's best (its simulated cost is about 1.8, the bowl's bottom 1.0):
  // it runs first in simulation, and then first on the robot.
  domain::EnqueuedGait g;
  g.source = "known.yaml";
  g.parameters = to_map(load_parameters(study::SpecDefaults::shipped().base_parameters_path));
  g.parameters["hip_offset"] = -0.2;
  g.parameters["hip_amplitude"] = 0.4;
  enqueue_ = {g};
  const auto uninterrupted = run_to_the_end("multi_fidelity", 4);
  const auto hardware = phase(uninterrupted, "hardware");
  const auto queued = phase(uninterrupted, study::kPhaseEnqueued);
  ASSERT_EQ(queued.size(), 1u);
  ASSERT_FALSE(hardware.empty());
  EXPECT_EQ(hardware.front()->x, queued.front()->x);
  ASSERT_TRUE(hardware.front()->proposal);
  EXPECT_EQ(hardware.front()->proposal->basis, "enqueued_gait");
  // The simulation found better than the queued gait: the rule, not the costs, put it first.
  const auto explored = phase(uninterrupted, "exploration");
  EXPECT_TRUE(std::any_of(explored.begin(), explored.end(),
                          [&](const auto* t) { return t->ok && t->cost < queued.front()->cost; }));
  // Killed before the first hardware proposal, with it in flight, and with the second in flight: the same
  // robot points, the enqueued flag rebuilt from the store's phase.
  struct Restart {
    int round;
    bool in_flight;
    int stored, done;  // hardware trials in the store at the kill
  };
  for (const Restart& r : {Restart{6, false, 0, 0}, Restart{7, true, 1, 0}, Restart{8, true, 2, 1}}) {
    SCOPED_TRACE(fmt::format("restart at round {}{}", r.round, r.in_flight ? " in flight" : ""));
    TearDown();
    open();
    const auto restarted = run_to_the_end("multi_fidelity", 4, r.round, r.in_flight);
    EXPECT_EQ(restarted_with_hardware_stored_, r.stored);
    EXPECT_EQ(restarted_with_hardware_done_, r.done);
    const auto points = hardware_points_of(restarted);
    ASSERT_EQ(points.size(), hardware.size());
    for (std::size_t i = 0; i < points.size(); ++i) EXPECT_EQ(points[i], hardware[i]->x) << "hardware point " << i;
    EXPECT_EQ(phase(restarted, "hardware").front()->proposal->basis, "enqueued_gait");
  }
}

TEST_F(HardwareModelTest, TheRobotsFallsReachItsModelAndItsFaultsSpendNothing) {
  // The robot falls wherever the hip offset is above its middle (the simulation never does); its first
  // rollout ends in a plant fault (a motor watchdog), which is run again, never spent.
  robot_falls = [](const domain::Candidate& c) { return c.parameters.at("hip_offset") > 0.0; };
  fault_first_robot_candidate_ = true;
  const study::StoredStudy s = run_to_the_end("multi_fidelity", 5);
  EXPECT_EQ(robot_candidates_, 6);  // 5 hardware trials, one of them issued twice
  int falls = 0;
  for (const auto* t : phase(s, "hardware")) {
    const auto report = study::stored_report(*t);
    ASSERT_TRUE(report);
    falls += report->fell();
  }
  const bo::HardwareModelState state = bo::hardware_model_state_from_json(s.hardware_model_state);
  EXPECT_EQ(state.hardware_observations, 5);
  // A fall on the robot is a result the model learns from (its fall classifier), and never the answer.
  EXPECT_EQ(state.have_hardware_fall, falls > 0);
  const domain::StudyState& last = out_.states.back();
  ASSERT_TRUE(last.has_recommendation);
  EXPECT_LE(last.recommendation.params.at("hip_offset"), 0.0);
  EXPECT_EQ(last.falls, falls);
  std::printf("robot falls: %d of 5 hardware rollouts\n", falls);
}

TEST_F(HardwareModelTest, WithModelThreadsBothKindsOfJobRunOffTheEventThreadAndTheStudyCompletes) {
  model_threads_ = 2;
  open();
  const study::StoredStudy s = run_to_the_end("multi_fidelity", 4);
  expect_the_answer_is_the_robots(s, out_.states.back(), 4);
  std::lock_guard<std::mutex> lock(jobs_mutex_);
  EXPECT_GT(model_jobs_, 4 + 12 - 6);  // at least the 4 hardware asks and a simulation job per model proposal
  EXPECT_EQ(job_threads_.count(std::this_thread::get_id()), 0u);
}

// The hardware points of a study run to its end, in trial order.
std::vector<Eigen::VectorXd> hardware_points(const study::StoredStudy& s) {
  std::vector<Eigen::VectorXd> out;
  for (const auto* t : phase(s, "hardware")) out.push_back(t->x);
  return out;
}

TEST_F(HardwareModelTest, ARestartInTheMiddleProposesTheSameHardwarePointsAsTheUninterruptedRun) {
  for (const std::string strategy : {"multi_fidelity", "transfer"}) {
    SCOPED_TRACE(strategy);
    const auto uninterrupted = run_to_the_end(strategy, 5);
    const auto expected = hardware_points(uninterrupted);
    // Restarted after the answers of round 9, and (another run) with round 10's candidates in flight.
    for (const bool in_flight : {false, true}) {
      SCOPED_TRACE(in_flight ? "candidates in flight" : "between rounds");
      TearDown();
      open();
      const auto restarted = run_to_the_end(strategy, 5, in_flight ? 10 : 9, in_flight);
      // The restart fell between hardware reports: some before it, and proposals after it.
      EXPECT_GT(restarted_with_hardware_done_, 0);
      EXPECT_LT(restarted_with_hardware_done_, 4);
      const auto points = hardware_points(restarted);
      ASSERT_EQ(points.size(), expected.size());
      for (std::size_t i = 0; i < points.size(); ++i) EXPECT_EQ(points[i], expected[i]) << "hardware point " << i;
      EXPECT_EQ(restarted.hardware_model_state, uninterrupted.hardware_model_state);
      // And the safety check each was sent with, to the bit (the same model, the same robot costs before it).
      const auto a = phase(restarted, "hardware"), b = phase(uninterrupted, "hardware");
      for (std::size_t i = 0; i < a.size(); ++i) {
        ASSERT_TRUE(a[i]->proposal && b[i]->proposal) << "hardware trial " << i;
        EXPECT_EQ(a[i]->proposal->basis, b[i]->proposal->basis) << "hardware trial " << i;
        EXPECT_EQ(a[i]->proposal->cost_bound, b[i]->proposal->cost_bound) << "hardware trial " << i;
        EXPECT_EQ(a[i]->proposal->cost_limit, b[i]->proposal->cost_limit) << "hardware trial " << i;
        EXPECT_EQ(a[i]->proposal->fall_probability, b[i]->proposal->fall_probability) << "hardware trial " << i;
      }
    }
    TearDown();
    open();
  }
}

TEST_F(HardwareModelTest, WithoutARobotTheSimulationRunsAndTheHardwareRolloutsWaitAndSaySo) {
  robot_ = false;
  const int id = submit(study_yaml("multi_fidelity", 3));
  run(40);
  auto s = store_->load(id);
  EXPECT_EQ(s->state, "running");
  EXPECT_EQ(phase(*s, "exploration").size(), 12u);
  EXPECT_EQ(phase(*s, "hardware").size(), 0u);  // nothing proposed while no robot could run it
  EXPECT_EQ(out_.states.back().message.rfind("waiting_for_hardware: multi_fidelity (0/3 hardware rollouts run)", 0), 0u)
      << out_.states.back().message;
  robot_ = true;  // the robot joins
  run(20);
  s = store_->load(id);
  EXPECT_EQ(s->state, "done") << s->message;
  EXPECT_EQ(phase(*s, "hardware").size(), 3u);
}

TEST_F(HardwareModelTest, AStoreWithoutTheHardwareStateColumnIsMigratedAndTheOptimizersStateKeepsIt) {
  const int id = submit(study_yaml("transfer", 2));
  run(40);
  nlohmann::json saved = store_->load(id)->hardware_model_state;
  ASSERT_TRUE(saved.is_object());
  // Saving the optimizer's state leaves the hardware model's alone.
  store_->save_model_state(id, store_->load(id)->model_state);
  EXPECT_EQ(store_->load(id)->hardware_model_state, saved);
  coordinator_.reset();
  store_.reset();
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path_.c_str(), &db), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(db, "ALTER TABLE model_states DROP COLUMN hardware_state_json", nullptr, nullptr, nullptr),
            SQLITE_OK);
  sqlite3_close(db);
  open();  // an older store: the column comes back, with no hardware state in it
  const auto s = store_->load(id);
  EXPECT_TRUE(s->hardware_model_state.is_null());
  EXPECT_TRUE(s->model_state.is_object());
}

TEST_F(HardwareModelTest, AStoreWithoutTheProposalColumnsReadsAndIsMigrated) {
  const int id = submit(study_yaml("transfer", 2));
  run(40);
  ASSERT_TRUE(phase(*store_->load(id), "hardware").front()->proposal);
  coordinator_.reset();
  store_.reset();
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path_.c_str(), &db), SQLITE_OK);
  for (const char* column : {"proposal_fall_probability", "proposal_within_fall_limit", "proposal_cost_bound",
                             "proposal_cost_limit", "proposal_within_cost_bound", "proposal_basis"}) {
    ASSERT_EQ(sqlite3_exec(db, fmt::format("ALTER TABLE trials DROP COLUMN {}", column).c_str(), nullptr, nullptr,
                           nullptr),
              SQLITE_OK)
        << column;
  }
  sqlite3_close(db);
  {
    // A reader (export, analyze) opens it read-only: nothing migrated, every trial read, none with a check.
    const study::StudyStore reader(path_, study::kReadOnly);
    const auto s = reader.load(id);
    ASSERT_TRUE(s);
    EXPECT_EQ(s->load_error, "");
    EXPECT_EQ(phase(*s, "hardware").size(), 2u);
    for (const auto& t : s->trials) EXPECT_FALSE(t.proposal) << "trial " << t.trial_id;
  }
  open();  // the service migrates it: the columns come back, NULL for the trials stored before
  const auto s = store_->load(id);
  EXPECT_EQ(phase(*s, "hardware").size(), 2u);
  for (const auto& t : s->trials) EXPECT_FALSE(t.proposal) << "trial " << t.trial_id;
}

TEST(HardwareConfig, TheHardwareKeyHasDefaultsRangesAndFileLineErrors) {
  const auto none = study::load_study_config_text("name: a\n", "s.yaml");
  EXPECT_EQ(none.hardware.strategy, study::HardwareStrategy::kNone);  // a plain study never waits for a robot
  EXPECT_FALSE(none.needs_hardware());
  const auto mf = study::load_study_config_text("name: a\ninitial_points: 8\nhardware: {strategy: multi_fidelity}\n", "s.yaml");
  EXPECT_TRUE(mf.hardware.models_hardware());
  EXPECT_EQ(mf.hardware.budget, 15);
  EXPECT_DOUBLE_EQ(mf.hardware.max_fall_probability, 0.2);
  EXPECT_DOUBLE_EQ(mf.hardware.safe_margin, 0.1);
  EXPECT_DOUBLE_EQ(mf.hardware.safe_beta, 2.0);
  EXPECT_EQ(mf.hardware.start_after, 8);  // the initial design
  EXPECT_FALSE(mf.validation.enabled);
  const auto t = study::load_study_config_text(
      "name: a\nhardware: {strategy: transfer, budget: 7, max_fall_probability: 0.1, start_after: 40}\n", "s.yaml");
  EXPECT_EQ(t.hardware.strategy, study::HardwareStrategy::kTransfer);
  EXPECT_EQ(t.hardware.budget, 7);
  EXPECT_DOUBLE_EQ(t.hardware.max_fall_probability, 0.1);
  EXPECT_EQ(t.hardware.start_after, 40);
  const auto safe = study::load_study_config_text(
      "name: a\nhardware: {strategy: transfer, safe_margin: 0.25, safe_beta: 1.5}\n", "s.yaml");
  EXPECT_DOUBLE_EQ(safe.hardware.safe_margin, 0.25);
  EXPECT_DOUBLE_EQ(safe.hardware.safe_beta, 1.5);
  EXPECT_DOUBLE_EQ(hardware_model_options(safe).safe_margin, 0.25);  // what the study's hardware model gets
  EXPECT_DOUBLE_EQ(hardware_model_options(safe).safe_beta, 1.5);
  // `validate` is the validation phase; `validation:` stays as its older spelling.
  const auto v = study::load_study_config_text("name: a\nhardware: {strategy: validate, budget: 4, spread: 0.2}\n", "s.yaml");
  EXPECT_TRUE(v.validation.enabled);
  EXPECT_EQ(v.validation.hardware_sets, 4);
  EXPECT_DOUBLE_EQ(v.validation.spread, 0.2);
  const auto old = study::load_study_config_text("name: a\nvalidation: {hardware_sets: 4}\n", "s.yaml");
  EXPECT_EQ(old.hardware.strategy, study::HardwareStrategy::kValidate);
  EXPECT_EQ(old.hardware.budget, 4);
  // Bad values name the field with file and line.
  for (const auto& [yaml, field] : std::vector<std::pair<std::string, std::string>>{
           {"name: a\nhardware: {strategy: sometimes}\n", "strategy"},
           {"name: a\nhardware: {budget: 3}\n", "strategy"},
           {"name: a\nhardware: {strategy: transfer, budget: 0}\n", "budget"},
           {"name: a\nhardware: {strategy: transfer, max_fall_probability: 1.5}\n", "max_fall_probability"},
           {"name: a\nhardware: {strategy: transfer, safe_margin: -0.1}\n", "safe_margin"},
           {"name: a\nhardware: {strategy: multi_fidelity, safe_margin: lots}\n", "safe_margin"},
           {"name: a\nhardware: {strategy: multi_fidelity, safe_beta: -2}\n", "safe_beta"},
           {"name: a\nhardware: {strategy: validate, safe_margin: 0.1}\n", "safe_margin"},
           {"name: a\ninitial_points: 10\nhardware: {strategy: transfer, start_after: 5}\n", "start_after"},
           {"name: a\nbudget: 20\nhardware: {strategy: transfer, start_after: 30}\n", "start_after"},
           {"name: a\nhardware: {strategy: transfer, spread: 0.1}\n", "spread"},
           {"name: a\nhardware: {strategy: validate, max_fall_probability: 0.1}\n", "max_fall_probability"},
           {"name: a\nvalidation: {}\nhardware: {strategy: validate}\n", "hardware"},
           {"name: a\nexplore_on: hardware\nhardware: {strategy: multi_fidelity}\n", "hardware"},
           {"name: a\nlockstep: 2\nhardware: {strategy: multi_fidelity}\n", "hardware"}}) {
    const std::string e = study_error(yaml);
    EXPECT_NE(e.find("s.yaml:"), std::string::npos) << yaml << " -> " << e;
    EXPECT_NE(e.find(field), std::string::npos) << yaml << " -> " << e;
  }
}

TEST(HardwareConfig, TheHardwareKeyIsPartOfTheSpecAndItsHash) {
  const auto defaults = study::SpecDefaults::shipped();
  const std::string base = "name: a\nbudget: 20\n";
  const auto plain = study::StudySpec::resolve(base, "s.yaml", defaults);
  const auto mf = study::StudySpec::resolve(base + "hardware: {strategy: multi_fidelity, budget: 5}\n", "s.yaml", defaults);
  const auto tr = study::StudySpec::resolve(base + "hardware: {strategy: transfer, budget: 5}\n", "s.yaml", defaults);
  const auto mf6 = study::StudySpec::resolve(base + "hardware: {strategy: multi_fidelity, budget: 6}\n", "s.yaml", defaults);
  EXPECT_NE(plain.sha256(), mf.sha256());
  EXPECT_NE(mf.sha256(), tr.sha256());
  EXPECT_NE(mf.sha256(), mf6.sha256());
  // The stored spec gives back the same study, hardware key included.
  const auto again = study::StudySpec::from_json_text(mf.canonical_json(), "stored");
  EXPECT_EQ(again.config().hardware.strategy, study::HardwareStrategy::kMultiFidelity);
  EXPECT_EQ(again.config().hardware.budget, 5);
  EXPECT_EQ(again.sha256(), mf.sha256());
}

// The robot's first rollout is the best simulated point told by then, so a new study waits for its whole
// simulated exploration by default, and says so in its spec; a spec stored before that default (no key)
// keeps the initial design, as it ran; a study file's own value is kept.
TEST(HardwareConfig, ANewStudyStartsTheRobotAfterItsWholeSimulationAndItsSpecSaysSo) {
  const auto defaults = study::SpecDefaults::shipped();
  const std::string base = "name: a\nbudget: 40\n";
  for (const char* strategy : {"multi_fidelity", "transfer"}) {
    SCOPED_TRACE(strategy);
    const auto spec = study::StudySpec::resolve(base + "hardware: {strategy: " + strategy + ", budget: 5}\n", "s.yaml", defaults);
    EXPECT_EQ(spec.config().hardware.start_after, 40);
    EXPECT_EQ(spec.tree()["study"]["hardware"]["start_after"], 40.0);
    const auto given = study::StudySpec::resolve(base + "hardware: {strategy: " + strategy + ", budget: 5, start_after: 20}\n",
                                                 "s.yaml", defaults);
    EXPECT_EQ(given.config().hardware.start_after, 20);
    // A spec stored before the default: the same tree without the key.
    nlohmann::json old_tree = nlohmann::json::parse(spec.canonical_json());
    old_tree["study"]["hardware"].erase("start_after");
    const auto stored = study::StudySpec::from_json_text(old_tree.dump(), "stored");
    EXPECT_EQ(stored.config().hardware.start_after, stored.config().optimizer.initial_points);
    EXPECT_NE(stored.sha256(), spec.sha256());
  }
  // Other strategies have no start: nothing is written.
  const auto validate = study::StudySpec::resolve(base + "hardware: {strategy: validate, budget: 3}\n", "s.yaml", defaults);
  EXPECT_FALSE(validate.tree()["study"]["hardware"].contains("start_after"));
}

}  // namespace
}  // namespace cpgmatch::service
