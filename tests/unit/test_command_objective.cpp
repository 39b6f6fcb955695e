// Rollouts as child processes (the simulation worker's slots run them this way, two or more at a time).
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "cpgmatch/command_objective.hpp"

namespace cpgmatch {
namespace {

TEST(CommandObjective, ReadsTheCostFromTheLastLineOfTheCommandsOutput) {
  const EvaluationOutcome out = run_command_objective("cat >/dev/null; echo progress; echo 1.25", "{}", 10.0);
  ASSERT_TRUE(out.ok) << out.message;
  EXPECT_DOUBLE_EQ(out.cost, 1.25);
  EXPECT_EQ(out.stdout_lines.size(), 2u);
}

TEST(CommandObjective, ConcurrentCommandsDoNotHoldEachOthersPipesOpen) {
  // Each command reads its stdin to the end, as a rollout reads its request. If one slot's child inherited
  // another slot's pipe ends (pipes without close-on-exec, created while the other thread forks), that
  // child would keep the other's stdin open: neither sees end-of-file and both hang until the timeout
  // (seen in CI: two rollouts of one worker killed at the same instant). Four threads, 40 commands each.
  constexpr int kThreads = 4, kRuns = 40;
  std::vector<int> failures(kThreads, 0);
  std::vector<std::string> last_message(kThreads);
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&, t] {
      for (int i = 0; i < kRuns; ++i) {
        const EvaluationOutcome out = run_command_objective("cat >/dev/null; echo 0.5", "{\"x\": 1}", 5.0);
        if (!out.ok) {
          ++failures[t];
          last_message[t] = out.message;
        }
      }
    });
  }
  for (auto& th : threads) th.join();
  for (int t = 0; t < kThreads; ++t) EXPECT_EQ(failures[t], 0) << "thread " << t << ": " << last_message[t];
}

}  // namespace
}  // namespace cpgmatch
