// The model's view of a study's parameters: importance from the GP's length scales and partial dependence,
// on studies whose cost depends on known parameters.
#include <cmath>

#include <gtest/gtest.h>

#include "cpgmatch/analysis/surrogate.hpp"

namespace cpgmatch::analysis {
namespace {

// 40 rollouts over a 2-D grid-like design; the cost depends on hip_offset only (a bowl with its bottom at
// 0.1) and not at all on overswing.
StudyTrials one_parameter_matters() {
  StudyTrials s;
  s.name = "bowl";
  s.seed = 7;
  s.dimensions = {{"hip_offset", -0.3, 0.3, false, "rad"}, {"overswing", 0.0, 0.5, false, ""}};
  for (const auto& d : s.dimensions) s.bounds[d.name] = {d.low, d.high};
  for (int i = 0; i < 40; ++i) {
    Trial t;
    t.trial_id = i;
    t.ok = true;
    const double x = -0.3 + 0.6 * std::fmod(0.618034 * i, 1.0), o = 0.5 * std::fmod(0.754878 * i + 0.3, 1.0);
    t.params = {{"hip_offset", x}, {"overswing", o}};
    t.cost = 1.0 + 20.0 * (x - 0.1) * (x - 0.1);
    s.trials.push_back(t);
  }
  return s;
}

TEST(Surrogate, TheParameterTheCostDependsOnMattersMost) {
  std::string why;
  const auto view = surrogate_view(one_parameter_matters(), &why);
  ASSERT_TRUE(view) << why;
  ASSERT_EQ(view->importance.size(), 2u);
  EXPECT_EQ(view->importance[0].name, "hip_offset");
  EXPECT_GT(view->importance[0].relevance, 0.8) << "overswing does nothing to the cost";
  EXPECT_NEAR(view->importance[0].relevance + view->importance[1].relevance, 1.0, 1e-12);
  EXPECT_NE(view->source.find("fitted here"), std::string::npos) << "no saved model: " << view->source;
}

TEST(Surrogate, PartialDependenceFindsTheBowlsBottom) {
  std::string why;
  const auto view = surrogate_view(one_parameter_matters(), &why, 61);
  ASSERT_TRUE(view) << why;
  const PartialDependence& pd = view->partial_dependence[0];
  ASSERT_EQ(pd.x.size(), 61u);
  EXPECT_DOUBLE_EQ(pd.x.front(), -0.3);
  EXPECT_DOUBLE_EQ(pd.x.back(), 0.3);
  std::size_t lowest = 0;
  for (std::size_t i = 1; i < pd.cost.size(); ++i) lowest = pd.cost[i] < pd.cost[lowest] ? i : lowest;
  EXPECT_NEAR(pd.x[lowest], 0.1, 0.03);
  EXPECT_NEAR(pd.cost[lowest], 1.0, 0.1);
  EXPECT_NEAR(pd.cost.front(), 1.0 + 20.0 * 0.16, 0.3);  // (-0.3 - 0.1)^2 * 20
}

TEST(Surrogate, ASavedModelsLengthScalesAreWhatItReports) {
  StudyTrials s = one_parameter_matters();
  // [log amplitude, log length scales (search-space order), log noise], as the optimizer saves them.
  s.model_hyperparameters = {0.0, std::log(0.2), std::log(5.0), std::log(1e-4)};
  s.model_observations = 40;
  std::string why;
  const auto view = surrogate_view(s, &why);
  ASSERT_TRUE(view) << why;
  EXPECT_NEAR(view->importance[0].length_scale, 0.2, 1e-12);
  EXPECT_NEAR(view->importance[1].length_scale, 5.0, 1e-12);
  EXPECT_NEAR(view->importance[0].relevance, (1 / 0.2) / (1 / 0.2 + 1 / 5.0), 1e-12);
  EXPECT_NE(view->source.find("saved hyperparameters (fit on 40 rollouts)"), std::string::npos) << view->source;
}

TEST(Surrogate, ALogCostModelAveragesLogCosts) {
  StudyTrials s = one_parameter_matters();
  s.log_cost = true;
  std::string why;
  const auto view = surrogate_view(s, &why);
  ASSERT_TRUE(view) << why;
  EXPECT_NE(view->source.find("log cost"), std::string::npos);
  for (double c : view->partial_dependence[1].cost) EXPECT_GT(c, 0.0) << "exp of a log cost is positive";
}

TEST(Surrogate, TooFewRolloutsSayWhy) {
  StudyTrials s = one_parameter_matters();
  s.trials.resize(2);
  std::string why;
  EXPECT_FALSE(surrogate_view(s, &why));
  EXPECT_NE(why.find("at least 3"), std::string::npos) << why;
}

}  // namespace
}  // namespace cpgmatch::analysis
