// The fall model: a GP classifier of where evaluations fall, and acquisitions weighted by the
// probability of not falling.
#include <cmath>

#include <gtest/gtest.h>

#include "cpgmatch/bo/fall_model.hpp"
#include "cpgmatch/bo/optimizer.hpp"

namespace cpgmatch::bo {
namespace {

TEST(SafeAcquisition, WithNoChanceOfFallingItIsThePlainAcquisition) {
  for (Acquisition a : {Acquisition::kExpectedImprovement, Acquisition::kProbabilityOfImprovement,
                        Acquisition::kLowerConfidenceBound}) {
    const auto plain = evaluate_acquisition(a, 0.7, 0.3, 0.9, 0.01, 1.96);
    const auto safe = evaluate_safe_acquisition(a, 0.7, 0.3, 1.0, 2.5, 0.9, 0.01, 1.96);
    EXPECT_NEAR(safe.value, plain.value, 1e-12) << to_string(a);
    EXPECT_NEAR(safe.d_mean, plain.d_mean, 1e-12) << to_string(a);
    EXPECT_NEAR(safe.d_std, plain.d_std, 1e-12) << to_string(a);
  }
}

TEST(SafeAcquisition, AProposalLikelyToFallIsWorthLess) {
  // EI and PI scale with P(no fall); the mixture's LCB moves towards the fall level.
  for (Acquisition a : {Acquisition::kExpectedImprovement, Acquisition::kProbabilityOfImprovement,
                        Acquisition::kLowerConfidenceBound}) {
    const double sure = evaluate_safe_acquisition(a, 0.7, 0.3, 1.0, 2.5, 0.9, 0.01, 1.96).value;
    const double risky = evaluate_safe_acquisition(a, 0.7, 0.3, 0.4, 2.5, 0.9, 0.01, 1.96).value;
    EXPECT_GT(risky, sure) << to_string(a);  // minimised: larger is worse
  }
  EXPECT_NEAR(evaluate_safe_acquisition(Acquisition::kExpectedImprovement, 0.7, 0.3, 0.4, 2.5, 0.9, 0.01, 1.96).value,
              0.4 * evaluate_acquisition(Acquisition::kExpectedImprovement, 0.7, 0.3, 0.9, 0.01, 1.96).value, 1e-12);
}

TEST(SafeAcquisition, DerivativesMatchFiniteDifferences) {
  const double mu = 0.7, sd = 0.3, p = 0.6, fall = 2.5, best = 0.9, xi = 0.01, kappa = 1.96, h = 1e-6;
  for (Acquisition a : {Acquisition::kExpectedImprovement, Acquisition::kProbabilityOfImprovement,
                        Acquisition::kLowerConfidenceBound}) {
    auto f = [&](double m, double s, double q) { return evaluate_safe_acquisition(a, m, s, q, fall, best, xi, kappa).value; };
    const auto v = evaluate_safe_acquisition(a, mu, sd, p, fall, best, xi, kappa);
    EXPECT_NEAR(v.d_mean, (f(mu + h, sd, p) - f(mu - h, sd, p)) / (2 * h), 1e-6) << to_string(a);
    EXPECT_NEAR(v.d_std, (f(mu, sd + h, p) - f(mu, sd - h, p)) / (2 * h), 1e-6) << to_string(a);
    EXPECT_NEAR(v.d_p, (f(mu, sd, p + h) - f(mu, sd, p - h)) / (2 * h), 1e-6) << to_string(a);
  }
}

// Points of the unit square; those with x0 > 0.6 fell.
void corner_data(Eigen::MatrixXd* X, std::vector<bool>* fell) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  *X = Eigen::MatrixXd(30, 2);
  fell->clear();
  for (int i = 0; i < 30; ++i) {
    X->row(i) << unit(rng), unit(rng);
    fell->push_back((*X)(i, 0) > 0.6);
  }
}

TEST(FallModel, LearnsWhereFallsHappenWithAGradientThatMatchesFiniteDifferences) {
  Eigen::MatrixXd X;
  std::vector<bool> fell;
  corner_data(&X, &fell);
  FallModel model;
  std::mt19937_64 rng(1);
  model.fit(X, fell, true, rng, nullptr);
  ASSERT_TRUE(model.active());
  EXPECT_GT(model.probability_safe(Eigen::Vector2d(0.2, 0.5)), 0.9);
  EXPECT_LT(model.probability_safe(Eigen::Vector2d(0.9, 0.5)), 0.1);
  // A point on the boundary, where the probability is neither 0 nor 1.
  Eigen::Vector2d u(0.4, 0.4);
  while (model.probability_safe(u) > 0.9 && u[0] < 0.9) u[0] += 0.005;
  ASSERT_GT(model.probability_safe(u), 0.05);
  const SafeProbability s = model.probability_safe_with_gradient(u);
  EXPECT_NEAR(s.p, model.probability_safe(u), 1e-12);
  EXPECT_LT(s.dp_dx[0], 0.0);  // towards the falls, less safe
  const double h = 1e-6;
  for (int d = 0; d < 2; ++d) {
    Eigen::Vector2d up = u, down = u;
    up[d] += h;
    down[d] -= h;
    const double fd = (model.probability_safe(up) - model.probability_safe(down)) / (2 * h);
    EXPECT_NEAR(s.dp_dx[d], fd, 1e-4 * std::max(1.0, std::abs(fd))) << d;
  }
  const Eigen::VectorXd many = model.probability_safe_many(X.transpose());
  for (int i = 0; i < 30; ++i) EXPECT_NEAR(many[i], model.probability_safe(X.row(i).transpose()), 1e-9);
}

TEST(FallModel, WithoutBothOutcomesItStaysOutOfTheWay) {
  Eigen::MatrixXd X;
  std::vector<bool> fell;
  corner_data(&X, &fell);
  std::vector<bool> none(fell.size(), false);
  FallModel model;
  std::mt19937_64 rng(1);
  model.fit(X, none, true, rng, nullptr);
  EXPECT_FALSE(model.active());
  EXPECT_EQ(model.probability_safe(Eigen::Vector2d(0.9, 0.5)), 1.0);
}

// A 2-D landscape like a gait study's: a bowl whose minimum (0.7, 0.7) lies beside a cliff (x0 + x1 > 1.5
// falls), and a corner where everything falls (x0 < 0.2). A fall costs more than any non-fall.
struct Outcome {
  double cost;
  bool fell;
};
Outcome cliff(const Eigen::VectorXd& x) {
  const bool fell = x[0] + x[1] > 1.5 || x[0] < 0.2;
  const double bowl = 0.3 + 2.0 * ((x[0] - 0.7) * (x[0] - 0.7) + (x[1] - 0.7) * (x[1] - 0.7));
  return {fell ? 5.0 + bowl : bowl, fell};
}

struct StudyResult {
  int falls_after_design = 0;
  double best = 0.0;
};
StudyResult run_cliff_study(bool fall_model, std::uint64_t seed) {
  const SearchSpace space({{"a", 0.0, 1.0, false, ""}, {"b", 0.0, 1.0, false, ""}});
  OptimizerOptions o;
  o.initial_points = 10;
  o.cost_transform = CostTransform::kLog;
  o.fall_model = fall_model;
  o.seed = seed;
  BayesianOptimizer opt(space, o);
  StudyResult r;
  r.best = 1e9;
  for (int i = 0; i < 40; ++i) {
    const auto x = opt.ask(1)[0];
    const Outcome out = cliff(x);
    opt.tell(x, out.cost, out.fell);
    if (i >= o.initial_points && out.fell) ++r.falls_after_design;
    if (!out.fell) r.best = std::min(r.best, out.cost);
  }
  return r;
}

TEST(FallModel, AStudyBesideACliffFallsLessWithTheFallModelAndStillFindsTheMinimum) {
  int falls_on = 0, falls_off = 0;
  double best_on = 0.0, best_off = 0.0;
  for (std::uint64_t seed = 1; seed <= 6; ++seed) {
    const StudyResult on = run_cliff_study(true, seed), off = run_cliff_study(false, seed);
    falls_on += on.falls_after_design;
    falls_off += off.falls_after_design;
    best_on += on.best / 6.0;
    best_off += off.best / 6.0;
  }
  std::printf("falls after the design (6 seeds x 30): fall model %d, without %d; mean best %.4f / %.4f\n", falls_on,
              falls_off, best_on, best_off);
  EXPECT_LT(falls_on, falls_off);
  EXPECT_LT(best_on, 0.3 + 0.05);  // the minimum is 0.3
}

TEST(FallModel, RestoringFromASavedModelStateIsExact) {
  // The fall model's hyperparameters are part of the saved state: a restarted study proposes what the
  // uninterrupted one does.
  const SearchSpace space({{"a", 0.0, 1.0, false, ""}, {"b", 0.0, 1.0, false, ""}});
  OptimizerOptions o;
  o.initial_points = 10;
  o.cost_transform = CostTransform::kLog;
  o.fall_model = true;
  o.seed = 4;
  BayesianOptimizer opt(space, o);
  for (int i = 0; i < 25; ++i) {
    const auto x = opt.ask(1)[0];
    const Outcome out = cliff(x);
    opt.tell(x, out.cost, out.fell);
  }
  ASSERT_TRUE(opt.fall_model().active());
  ASSERT_TRUE(opt.model_state().have_fall_hyperparameters);
  BayesianOptimizer restored = BayesianOptimizer::restore(space, o, opt.observations(), opt.model_state());
  EXPECT_EQ(restored.ask(1)[0], opt.ask(1)[0]);
  const std::vector<Eigen::VectorXd> pending = {opt.ask(1)[0]};
  EXPECT_EQ(restored.ask(2, pending), opt.ask(2, pending));
  // Replaying the observations one by one gives the same optimizer too.
  BayesianOptimizer rebuilt = BayesianOptimizer::rebuild(space, o, opt.observations());
  EXPECT_EQ(rebuilt.ask(1)[0], opt.ask(1)[0]);
}

}  // namespace
}  // namespace cpgmatch::bo
