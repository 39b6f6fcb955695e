// The study's answer is the point the GP believes best, not the luckiest rollout.
#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "cpgmatch/analysis/recommendation.hpp"

namespace cpgmatch::analysis {
namespace {

Trial at(int id, double x, double cost) {
  Trial t;
  t.trial_id = id;
  t.ok = true;
  t.cost = cost;
  t.params = {{"hip_offset", x}, {"frequency", 1.0}};
  return t;
}

// A noisy bowl with its minimum (1.0) at x = 0.7, sampled densely; one rollout at x = 0.1 got lucky
// (0.3, below anything the bowl gives) while its close neighbours cost about 3.
StudyTrials lucky_outlier_study() {
  StudyTrials s;
  s.bounds = {{"hip_offset", {0.0, 1.0}}};
  std::mt19937_64 rng(3);
  std::normal_distribution<double> noise(0.0, 0.15);
  int id = 0;
  for (int i = 0; i <= 40; ++i) {
    const double x = i / 40.0;
    s.trials.push_back(at(id++, x, 1.0 + 8.0 * (x - 0.7) * (x - 0.7) + noise(rng)));
  }
  s.trials.push_back(at(id++, 0.1, 0.3));
  return s;
}

TEST(Recommendation, IgnoresALuckySampleAndPicksTheBottomOfTheBowl) {
  const StudyTrials s = lucky_outlier_study();
  const auto rec = recommend(s);
  ASSERT_TRUE(rec.has_value());
  const double x = rec->params.at("hip_offset");
  EXPECT_NEAR(x, 0.7, 0.1) << "recommended rollout " << rec->rollout << " cost " << rec->observed_cost;
  EXPECT_GT(rec->predicted_cost, 0.6);  // the GP's view of the bowl's floor, not the outlier's 0.3
  EXPECT_LT(rec->predicted_cost, 1.4);
  EXPECT_EQ(rec->params.at("frequency"), 1.0);  // fixed parameters come along unchanged
}

TEST(Recommendation, IsDeterministicAndNeedsTwoRollouts) {
  const StudyTrials s = lucky_outlier_study();
  EXPECT_EQ(recommend(s)->rollout, recommend(s)->rollout);
  StudyTrials one;
  one.bounds = s.bounds;
  one.trials = {at(0, 0.5, 1.0)};
  EXPECT_FALSE(recommend(one).has_value());
}

}  // namespace
}  // namespace cpgmatch::analysis
