// GP posterior and marginal likelihood against hand computations and finite differences.
#include <cmath>
#include <iostream>
#include <random>

#include <gtest/gtest.h>

#include "cpgmatch/bo/gaussian_process.hpp"

namespace cpgmatch::bo {
namespace {

double matern52(double r) { return (1 + std::sqrt(5.0) * r + 5.0 / 3.0 * r * r) * std::exp(-std::sqrt(5.0) * r); }

TEST(Kernel, TheMaternPolicysValueAndSlopeMatchTheFormulaAndItsDerivative) {
  // The one place the kernel is written: value(r) is Matern 5/2, slope(r) = -(1/r) dvalue/dr (every
  // gradient of every GP is built on it), and value_and_slope() gives the same two.
  Eigen::ArrayXd r(5);
  r << 0.0, 0.05, 0.4, 1.3, 4.0;
  const Eigen::ArrayXd value = Matern52::value(r), slope = Matern52::slope(r);
  Eigen::ArrayXd both_value, both_slope;
  Matern52::value_and_slope(r, both_value, both_slope);
  const double h = 1e-6;
  for (int i = 0; i < r.size(); ++i) {
    EXPECT_NEAR(value[i], matern52(r[i]), 1e-14) << r[i];
    EXPECT_NEAR(both_value[i], value[i], 1e-15) << r[i];
    EXPECT_NEAR(both_slope[i], slope[i], 1e-15) << r[i];
    if (r[i] > 0.0) {
      const double dvalue = (matern52(r[i] + h) - matern52(r[i] - h)) / (2 * h);
      EXPECT_NEAR(slope[i], -dvalue / r[i], 1e-7) << r[i];
    }
  }
  EXPECT_NEAR(slope[0], 5.0 / 3.0, 1e-15);  // the limit at r = 0
}

TEST(GaussianProcess, PosteriorMatchesHandComputedTwoPointCase) {
  // Two 1-D points, amplitude 1, length scale 0.5, noise 1e-4; y = [1, -1] has mean 0 and std 1, so the
  // standardised targets equal the raw ones.
  Eigen::MatrixXd X(2, 1);
  X << 0.2, 0.7;
  Eigen::VectorXd y(2);
  y << 1.0, -1.0;
  GpHyperparameters h;
  h.log_amplitude = 0.0;
  h.log_length_scales = Eigen::VectorXd::Constant(1, std::log(0.5));
  h.log_noise = std::log(1e-4);
  GaussianProcess gp;
  std::mt19937_64 rng(0);
  gp.fit(X, y, /*optimise=*/false, rng, &h);

  const double x = 0.4;
  const double k12 = matern52(0.5 / 0.5);
  const double k1 = matern52(0.2 / 0.5), k2 = matern52(0.3 / 0.5);
  // K = [[1+n, k12], [k12, 1+n]]; explicit 2x2 inverse.
  const double a = 1.0 + 1e-4, det = a * a - k12 * k12;
  const double inv11 = a / det, inv12 = -k12 / det;
  const double alpha1 = inv11 * 1.0 + inv12 * -1.0, alpha2 = inv12 * 1.0 + inv11 * -1.0;
  const double mean = k1 * alpha1 + k2 * alpha2;
  const double var = 1.0 - (k1 * (inv11 * k1 + inv12 * k2) + k2 * (inv12 * k1 + inv11 * k2));

  const Prediction p = gp.predict(Eigen::VectorXd::Constant(1, x));
  EXPECT_NEAR(p.mean, mean, 1e-9);
  EXPECT_NEAR(p.std, std::sqrt(var), 1e-9);
}

TEST(GaussianProcess, TheInverseFromTheCholeskyFactorIsTheInverse) {
  // Sizes below, at and across the 32-column blocks.
  std::mt19937_64 rng(5);
  std::normal_distribution<double> g(0.0, 1.0);
  for (int n : {1, 7, 32, 33, 100}) {
    Eigen::MatrixXd A(n, n);
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j) A(i, j) = g(rng);
    Eigen::MatrixXd K = A * A.transpose() + n * Eigen::MatrixXd::Identity(n, n);
    Eigen::LLT<Eigen::MatrixXd> llt(K);
    const Eigen::MatrixXd L = llt.matrixL();
    const Eigen::MatrixXd Kinv = inverse_from_cholesky(L);
    const Eigen::MatrixXd reference = llt.solve(Eigen::MatrixXd::Identity(n, n));
    EXPECT_LT((Kinv - reference).cwiseAbs().maxCoeff(), 1e-12 * reference.cwiseAbs().maxCoeff()) << "n = " << n;
    EXPECT_EQ(Kinv, Kinv.transpose()) << "n = " << n;
  }
}

TEST(GaussianProcess, MarginalLikelihoodGradientMatchesFiniteDifferences) {
  for (int n : {12, 90}) {  // 90: several blocks of the inverse
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Eigen::MatrixXd X(n, 3);
  Eigen::VectorXd y(n);
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < 3; ++j) X(i, j) = u(rng);
    y[i] = std::sin(3 * X(i, 0)) + X(i, 1) * X(i, 2);
  }
  GaussianProcess gp;
  gp.fit(X, y, false, rng);
  Eigen::VectorXd theta(5);
  theta << 0.3, std::log(0.4), std::log(0.9), std::log(0.2), std::log(1e-3);
  Eigen::VectorXd grad;
  gp.log_marginal_likelihood(theta, &grad);
  for (int i = 0; i < theta.size(); ++i) {
    const double h = 1e-6;
    Eigen::VectorXd tp = theta, tm = theta;
    tp[i] += h;
    tm[i] -= h;
    const double fd = (gp.log_marginal_likelihood(tp, nullptr) - gp.log_marginal_likelihood(tm, nullptr)) / (2 * h);
    EXPECT_NEAR(grad[i], fd, 1e-4 * std::max(1.0, std::abs(fd))) << "n = " << n << ", theta[" << i << "]";
  }
  }
}

TEST(GaussianProcess, AWarmStartedFitStopsOnceTheLikelihoodStopsImprovingAndReachesTheSameOptimum) {
  // The hyperparameters optimised on 95 points warm-start the fit on 100, as the optimizer's schedule does.
  // With the absolute tolerance (GpOptions::likelihood_tolerance) the search stops when a step changes the
  // likelihood by less than that: fewer likelihood evaluations (each O(n^3)), and a likelihood within 1e-3
  // nats of the search run to the relative tolerance alone.
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const int n = 100, d = 4;
  Eigen::MatrixXd X(n, d);
  Eigen::VectorXd y(n);
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < d; ++j) X(i, j) = u(rng);
    y[i] = std::sin(4 * X(i, 0)) * std::exp(-X(i, 1)) + 0.5 * X(i, 2) * X(i, 2) - 0.2 * X(i, 3);
  }
  GaussianProcess first;
  first.fit(X.topRows(95), y.head(95), true, rng);
  GaussianProcess gp;
  gp.fit(X, y, false, rng, &first.hyperparameters());
  GpOptions options;
  options.likelihood_tolerance = 1e-4;  // the value measured in docs/optimizer.md (off by default)
  const Eigen::VectorXd lb = options.lower_bounds(d), ub = options.upper_bounds(d);
  const Eigen::VectorXd start = first.hyperparameters().pack().cwiseMax(lb).cwiseMin(ub);
  int evaluations = 0;
  auto f = [&](const Eigen::VectorXd& theta, Eigen::VectorXd* grad) {
    ++evaluations;
    return gp.log_marginal_likelihood(theta, grad);
  };
  const Eigen::VectorXd tight = maximise_from_starts(f, {start}, lb, ub, 200, 0.0);
  const int tight_evaluations = evaluations;
  evaluations = 0;
  const Eigen::VectorXd loose = maximise_from_starts(f, {start}, lb, ub, 200, options.likelihood_tolerance);
  const int loose_evaluations = evaluations;
  const double tight_lml = gp.log_marginal_likelihood(tight, nullptr), loose_lml = gp.log_marginal_likelihood(loose, nullptr);
  EXPECT_GT(loose_lml, gp.log_marginal_likelihood(start, nullptr));  // it did optimise
  EXPECT_GT(loose_lml, tight_lml - 1e-3);
  EXPECT_LT(loose_evaluations, tight_evaluations);
  std::cout << "evaluations: " << tight_evaluations << " (relative 1e-9) -> " << loose_evaluations << " (absolute " << options.likelihood_tolerance << "); LML "
            << tight_lml << " -> " << loose_lml << "\n";
}

TEST(GaussianProcess, PredictionGradientMatchesFiniteDifferences) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Eigen::MatrixXd X(10, 2);
  Eigen::VectorXd y(10);
  for (int i = 0; i < 10; ++i) {
    X(i, 0) = u(rng);
    X(i, 1) = u(rng);
    y[i] = std::cos(4 * X(i, 0)) * X(i, 1);
  }
  GaussianProcess gp;
  gp.fit(X, y, true, rng);
  Eigen::VectorXd x(2);
  x << 0.33, 0.61;
  Eigen::VectorXd dm, ds;
  gp.predict_with_gradient(x, &dm, &ds);
  for (int i = 0; i < 2; ++i) {
    const double h = 1e-6;
    Eigen::VectorXd xp = x, xm = x;
    xp[i] += h;
    xm[i] -= h;
    EXPECT_NEAR(dm[i], (gp.predict(xp).mean - gp.predict(xm).mean) / (2 * h), 1e-5);
    EXPECT_NEAR(ds[i], (gp.predict(xp).std - gp.predict(xm).std) / (2 * h), 1e-5);
  }
}

TEST(GaussianProcess, DuplicatePointsNeverGiveNaN) {
  Eigen::MatrixXd X = Eigen::MatrixXd::Constant(6, 2, 0.5);  // six identical inputs: singular kernel
  Eigen::VectorXd y(6);
  y << 1, 2, 3, 1, 2, 3;
  GaussianProcess gp(GpOptions{.min_noise = 1e-12});
  std::mt19937_64 rng(1);
  gp.fit(X, y, true, rng);
  const Prediction p = gp.predict(Eigen::Vector2d(0.5, 0.5));
  EXPECT_TRUE(std::isfinite(p.mean));
  EXPECT_TRUE(std::isfinite(p.std));
  Eigen::VectorXd mean, std;
  gp.predict_many(Eigen::MatrixXd::Constant(2, 3, 0.25), &mean, &std);
  EXPECT_TRUE(mean.allFinite());
  EXPECT_TRUE(std.allFinite());
}

TEST(GaussianProcess, BatchPredictionEqualsSinglePrediction) {
  std::mt19937_64 rng(9);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Eigen::MatrixXd X(15, 2);
  Eigen::VectorXd y(15);
  for (int i = 0; i < 15; ++i) {
    X(i, 0) = u(rng);
    X(i, 1) = u(rng);
    y[i] = X(i, 0) - 2 * X(i, 1) * X(i, 1);
  }
  GaussianProcess gp;
  gp.fit(X, y, true, rng);
  Eigen::MatrixXd C(2, 4);
  C << 0.1, 0.5, 0.9, 0.3, 0.2, 0.8, 0.4, 0.6;
  Eigen::VectorXd mean, std;
  gp.predict_many(C, &mean, &std);
  for (int j = 0; j < 4; ++j) {
    const Prediction p = gp.predict(C.col(j));
    EXPECT_NEAR(mean[j], p.mean, 1e-9);
    EXPECT_NEAR(std[j], p.std, 1e-9 + 1e-4 * p.std);  // round-off in 1 - k^T K^-1 k near data
  }
}

// A model of the size a paper study's GP reaches: n points uniform in the 6-D unit cube with a smooth
// log-bowl cost and a little noise, hyperparameters fitted; for the factor-update tests. The generator
// is returned too, to draw the test's further points from.
struct FittedBowl {
  std::mt19937_64 rng;
  Eigen::MatrixXd X;
  Eigen::VectorXd y;
  GaussianProcess gp;
};

FittedBowl fitted_log_bowl_6d(unsigned seed, int n) {
  FittedBowl f{std::mt19937_64(seed), Eigen::MatrixXd(n, 6), Eigen::VectorXd(n), GaussianProcess()};
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < 6; ++j) f.X(i, j) = unit(f.rng);
    f.y[i] = std::log(0.1 + (f.X.row(i).array() - 0.4).square().sum()) + 0.01 * unit(f.rng);
  }
  f.gp.fit(f.X, f.y, /*optimise=*/true, f.rng);
  return f;
}

TEST(GaussianProcess, AppendingPointsToTheFactorEqualsARefitOnTheExtendedData) {
  // A fitted 6-D model of 150 points, then the fake results of a batch: 60 pending points at once, then
  // one at a time (what ask() does); each step against refit_fixed() on the same data.
  const int d = 6, n = 150;
  FittedBowl bowl = fitted_log_bowl_6d(3, n);
  ASSERT_EQ(bowl.gp.jitter(), 0.0);
  auto& [rng, X, y, grown] = bowl;
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  GaussianProcess refit = grown;
  Eigen::MatrixXd Xall = X;
  Eigen::VectorXd yall = y;
  Eigen::MatrixXd probes(d, 50);
  for (int c = 0; c < probes.cols(); ++c)
    for (int j = 0; j < d; ++j) probes(j, c) = unit(rng);
  for (int batch : {60, 1, 1, 1, 5}) {
    Eigen::MatrixXd U(batch, d);
    Eigen::VectorXd lies(batch);
    for (int i = 0; i < batch; ++i) {
      for (int j = 0; j < d; ++j) U(i, j) = unit(rng);
      lies[i] = grown.predict(U.row(i).transpose()).mean;  // the kriging believer's lie
    }
    grown.append_fixed(U, lies);
    Xall.conservativeResize(Xall.rows() + batch, Eigen::NoChange);
    Xall.bottomRows(batch) = U;
    yall.conservativeResize(yall.size() + batch);
    yall.tail(batch) = lies;
    refit.refit_fixed(Xall, yall);
    ASSERT_EQ(grown.num_points(), refit.num_points());
    Eigen::VectorXd m1, s1, m2, s2;
    grown.predict_many(probes, &m1, &s1);
    refit.predict_many(probes, &m2, &s2);
    for (int c = 0; c < probes.cols(); ++c) {
      EXPECT_NEAR(m1[c], m2[c], 1e-9) << "batch " << batch << " probe " << c;
      EXPECT_NEAR(s1[c], s2[c], 1e-9) << "batch " << batch << " probe " << c;
      Eigen::VectorXd dm1, ds1, dm2, ds2;
      const Prediction p1 = grown.predict_with_gradient(probes.col(c), &dm1, &ds1);
      const Prediction p2 = refit.predict_with_gradient(probes.col(c), &dm2, &ds2);
      EXPECT_NEAR(p1.std, p2.std, 1e-9);
      EXPECT_LT((dm1 - dm2).lpNorm<Eigen::Infinity>(), 1e-9);
      EXPECT_LT((ds1 - ds2).lpNorm<Eigen::Infinity>(), 1e-9);
    }
  }
  EXPECT_EQ(grown.num_points(), n + 68);
}

TEST(GaussianProcess, ACandidatePosteriorExtendedThroughAppendedPointsEqualsAFreshFactorisation) {
  // What ask() does for a batch: the posterior of 1000 candidates computed once, then extended by the rows
  // each appended lie adds to the factor. After every step it must equal predict_many() on refit_fixed()
  // of the same data (a fresh kernel, factorisation and solve), and at the start predict_many() exactly.
  const int d = 6, n = 150;
  FittedBowl bowl = fitted_log_bowl_6d(5, n);
  ASSERT_EQ(bowl.gp.jitter(), 0.0);
  auto& [rng, X, y, grown] = bowl;
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  Eigen::MatrixXd C(d, 1000);
  for (int c = 0; c < C.cols(); ++c)
    for (int j = 0; j < d; ++j) C(j, c) = unit(rng);
  CandidatePosterior cp = grown.candidate_posterior(C);
  Eigen::VectorXd m0, s0, m1, s1;
  grown.predict_many(C, &m0, &s0);
  grown.predict_candidates(cp, &m1, &s1);
  EXPECT_EQ(m0, m1);
  EXPECT_EQ(s0, s1);
  GaussianProcess refit = grown;
  Eigen::MatrixXd Xall = X;
  Eigen::VectorXd yall = y;
  for (int batch : {60, 1, 1, 1, 5}) {
    Eigen::MatrixXd U(batch, d);
    Eigen::VectorXd lies(batch);
    for (int i = 0; i < batch; ++i) {
      for (int j = 0; j < d; ++j) U(i, j) = unit(rng);
      lies[i] = grown.predict(U.row(i).transpose()).mean + 0.3 * (unit(rng) - 0.5);  // not only the mean
    }
    ASSERT_TRUE(grown.append_fixed(U, lies));
    grown.extend(cp);
    ASSERT_EQ(cp.rows, grown.num_points());
    Xall.conservativeResize(Xall.rows() + batch, Eigen::NoChange);
    Xall.bottomRows(batch) = U;
    yall.conservativeResize(yall.size() + batch);
    yall.tail(batch) = lies;
    refit.refit_fixed(Xall, yall);
    Eigen::VectorXd m2, s2;
    grown.predict_candidates(cp, &m1, &s1);
    refit.predict_many(C, &m2, &s2);
    for (int c = 0; c < C.cols(); ++c) {
      ASSERT_NEAR(m1[c], m2[c], 1e-9) << "batch " << batch << " candidate " << c;
      ASSERT_NEAR(s1[c], s2[c], 1e-9) << "batch " << batch << " candidate " << c;
    }
  }
}

TEST(GaussianProcess, AppendingADuplicatePointFallsBackToAJitteredRefit) {
  // A point already in a noiseless model: the extended factor is not positive definite, and the result is
  // refit_fixed()'s (jitter added), never NaN.
  Eigen::MatrixXd X(3, 1);
  X << 0.1, 0.5, 0.9;
  Eigen::VectorXd y(3);
  y << 1.0, 0.0, 2.0;
  GpHyperparameters h;
  h.log_length_scales = Eigen::VectorXd::Constant(1, std::log(0.3));
  h.log_noise = std::log(1e-300);
  GaussianProcess grown;
  std::mt19937_64 rng(0);
  grown.fit(X, y, false, rng, &h);
  GaussianProcess refit = grown;
  Eigen::MatrixXd U(1, 1);
  U << 0.5;
  Eigen::VectorXd v(1);
  v << 0.0;
  EXPECT_FALSE(grown.append_fixed(U, v));  // refactorised: a CandidatePosterior must start again
  Eigen::MatrixXd Xall(4, 1);
  Xall << X, U;
  Eigen::VectorXd yall(4);
  yall << y, v;
  refit.refit_fixed(Xall, yall);
  EXPECT_EQ(grown.jitter(), refit.jitter());
  const Prediction a = grown.predict(Eigen::VectorXd::Constant(1, 0.3)), b = refit.predict(Eigen::VectorXd::Constant(1, 0.3));
  EXPECT_TRUE(std::isfinite(a.mean) && std::isfinite(a.std));
  EXPECT_NEAR(a.mean, b.mean, 1e-12);
  EXPECT_NEAR(a.std, b.std, 1e-12);
}

}  // namespace
}  // namespace cpgmatch::bo
