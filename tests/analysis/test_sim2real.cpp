// Simulation versus hardware (Supplementary Table 3) from a synthetic study store: known cost terms on
// simulation and hardware rollouts, read back through the store as `cpgmatch sim2real` does.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <filesystem>

#include "cpgmatch/analysis/gnuplot.hpp"
#include "cpgmatch/analysis/sim2real.hpp"
#include "cpgmatch/analysis/stored_study_trials.hpp"
#include "cpgmatch/study/study_store.hpp"

namespace cpgmatch::analysis {
namespace {

namespace fs = std::filesystem;

domain::RolloutReport report(int study, int trial, bool hardware, double feedback, double distance, double pitch) {
  domain::RolloutReport r;
  r.id.study_id = study;
  r.id.trial_id = trial;
  r.worker_id = hardware ? "robot" : "sim";
  r.worker_kind = hardware ? domain::WorkerKind::kHardware : domain::WorkerKind::kSimulation;
  r.summary.terms = CostTerms{feedback, distance, pitch, 0.05, 0.01};
  r.summary.cost = feedback + distance + pitch + 0.05 + 0.01;
  return r;
}

class Sim2RealTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("sim2real-" + std::to_string(getpid()));
    fs::create_directories(dir_);
    store_path_ = (dir_ / "s.db").string();
    study::StudyStore store(store_path_);
    const int id = store.create_study("mixed", "name: mixed\nbudget: 4\ninitial_points: 2\n", "s.yaml", 1.7e9);
    // Four simulation rollouts (feedback 0.1..0.4), then three hardware validation sets.
    std::vector<study::StoredTrial> trials;
    for (int i = 0; i < 7; ++i) {
      study::StoredTrial t;
      t.trial_id = i;
      t.x = Eigen::VectorXd::Constant(6, 0.1);
      t.x[1] = 0.5;  // inside every paper bound
      t.worker_id = i < 4 ? "sim" : "robot";
      t.phase = i < 4 ? "exploration" : "validation";
      trials.push_back(t);
    }
    store.add_trials(id, trials);
    for (int i = 0; i < 4; ++i) store.complete_trial(report(id, i, false, 0.1 * (i + 1), 1.6, 0.8), 1.7e9);
    const double hw_feedback[] = {0.40, 0.45, 0.50};
    for (int i = 0; i < 3; ++i) store.complete_trial(report(id, 4 + i, true, hw_feedback[i], 2.0 + 0.1 * i, 0.9), 1.7e9);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
  std::string store_path_;
};

TEST_F(Sim2RealTest, MeansAndSdsPerTermAndTotalForEachKindOfWorker) {
  const StudyTrials trials = trials_from_stored_study(load_stored_study(store_path_, 0));
  ASSERT_EQ(trials.trials.size(), 7u);
  const Sim2RealTable t = sim2real_table(trials);
  EXPECT_EQ(t.sim_rollouts, 4);
  EXPECT_EQ(t.hw_rollouts, 3);
  EXPECT_EQ(t.sim_best_trial, 0);
  ASSERT_EQ(t.rows.size(), 6u);
  EXPECT_EQ(t.rows[0].term, "J_feedback");
  EXPECT_NEAR(t.rows[0].sim_mean, 0.25, 1e-12);
  EXPECT_NEAR(t.rows[0].sim_sd, std::sqrt(0.05 / 3.0), 1e-12);  // sample sd of 0.1..0.4
  EXPECT_NEAR(t.rows[0].sim_best, 0.1, 1e-12);
  EXPECT_NEAR(t.rows[0].hw_mean, 0.45, 1e-12);
  EXPECT_NEAR(t.rows[0].hw_sd, 0.05, 1e-12);
  EXPECT_EQ(t.rows[0].paper_hw, "0.43 ± 0.06");
  EXPECT_EQ(t.rows[1].term, "J_distance");
  EXPECT_NEAR(t.rows[1].hw_mean, 2.1, 1e-12);
  EXPECT_EQ(t.rows[5].term, "total");
  EXPECT_NEAR(t.rows[5].hw_mean, 0.45 + 2.1 + 0.9 + 0.06, 1e-12);
  const auto j = sim2real_json(t);
  EXPECT_EQ(j["hardware_rollouts"], 3);
  EXPECT_NEAR(j["terms"][1]["hardware"]["mean"].get<double>(), 2.1, 1e-12);
  EXPECT_EQ(j["terms"][3]["paper"]["hardware"], "");  // the paper gives no J_contact
  const std::string text = sim2real_text(t);
  EXPECT_NE(text.find("J_periodicity"), std::string::npos) << text;
  EXPECT_NE(text.find("4 simulation, 3 hardware"), std::string::npos) << text;
}

TEST_F(Sim2RealTest, TheScienceReportSeesOnlyTheExplorationOfAMixedStudy) {
  const StudyTrials trials = trials_from_stored_study(load_stored_study(store_path_, 0));
  const StudyTrials explored = exploration_trials(trials);
  ASSERT_EQ(explored.trials.size(), 4u);
  for (const auto& r : explored.trials) EXPECT_FALSE(r.hardware);
  StudyTrials hardware_only = trials;
  std::erase_if(hardware_only.trials, [](const Trial& r) { return !r.hardware; });
  EXPECT_EQ(exploration_trials(hardware_only).trials.size(), 3u);  // a hardware-only study stays whole
  const Sim2RealTable none = sim2real_table(explored);
  EXPECT_EQ(none.hw_rollouts, 0);
  EXPECT_TRUE(std::isnan(none.rows[0].hw_mean));
}

TEST_F(Sim2RealTest, ThePlotHasHardwareDotsOverTheSimulationLines) {
  if (!gnuplot_available()) GTEST_SKIP() << "no gnuplot";
  const StudyTrials trials = trials_from_stored_study(load_stored_study(store_path_, 0));
  const auto files = plot_sim2real(trials, dir_ / "fig");
  ASSERT_EQ(files.size(), 2u);
  for (const auto& f : files) EXPECT_GT(fs::file_size(f), 1000u) << f;
  EXPECT_TRUE(fs::exists(dir_ / "fig" / "sim2real.svg"));
}

}  // namespace
}  // namespace cpgmatch::analysis
