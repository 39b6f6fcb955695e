// Two simulated robots stepped at the same time on two threads of one process (a calibration or a benchmark
// that runs rollouts side by side) each compute exactly what they compute alone: ODE's worlds share no
// stepping state.
#include <gtest/gtest.h>

#include <thread>
#include <vector>

#include "cpgmatch/sim/sim_rollout.hpp"

namespace cpgmatch::sim {
namespace {

SimRolloutJob trot_job(std::uint64_t seed) {
  SimRolloutJob job;
  job.params = load_parameters(config_dir() + "/params/matched-trot.yaml");
  job.settings = load_rollout_settings(default_rollout_settings_path());
  job.settings.entrain_s = 1.0;
  job.settings.eval_s = 2.0;
  job.model = load_model_file(default_model_path());
  job.terrain = TerrainSpec::parse("rough:0.003");
  job.seed = seed;
  return job;
}

TEST(ParallelWorlds, RolloutsOnTwoThreadsAtOnceEqualTheSameRolloutsRunAlone) {
  constexpr int kThreads = 2;
  constexpr int kRolloutsPerThread = 3;
  std::vector<std::vector<double>> alone(kThreads), together(kThreads);
  for (int t = 0; t < kThreads; ++t) {
    for (int k = 0; k < kRolloutsPerThread; ++k) alone[t].push_back(run_sim_rollout(trot_job(10 * t + k)).cost);
  }
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([t, &together] {
      for (int k = 0; k < kRolloutsPerThread; ++k) together[t].push_back(run_sim_rollout(trot_job(10 * t + k)).cost);
    });
  }
  for (auto& th : threads) th.join();
  for (int t = 0; t < kThreads; ++t) {
    ASSERT_EQ(together[t].size(), alone[t].size());
    for (int k = 0; k < kRolloutsPerThread; ++k) {
      EXPECT_EQ(together[t][k], alone[t][k]) << "thread " << t << " rollout " << k;  // to the bit
    }
  }
}

}  // namespace
}  // namespace cpgmatch::sim
