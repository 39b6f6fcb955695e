// Gaussian-process regression for Bayesian optimisation, as scikit-optimize configures it:
//
//   k(x, x') = amplitude * Kernel(r),  Kernel = Matern52 (kernel.hpp),  r^2 = sum_d (x_d - x'_d)^2 / l_d^2   (one length scale per dim)
//   K = k(X, X) + noise * I
//
// Inputs are expected in the unit cube; outputs are standardised internally (zero mean, unit variance)
// and predictions are returned in the original units. Hyperparameters (log amplitude, log length
// scales, log noise) maximise the log marginal likelihood with analytic gradients (NLopt L-BFGS) from
// the previous optimum plus random restarts. Predictions exclude the noise term (latent f), like
// scikit-optimize. The Cholesky factorisation retries with growing jitter, so a posterior is never NaN.
#pragma once

#include <cstdint>
#include <functional>
#include <random>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Cholesky>

#include "cpgmatch/bo/kernel.hpp"

namespace cpgmatch::bo {

struct GpHyperparameters {
  double log_amplitude = 0.0;
  Eigen::VectorXd log_length_scales;
  double log_noise = std::log(1e-2);

  // Packs into [log_amplitude, log_length_scales..., log_noise].
  Eigen::VectorXd pack() const;
  static GpHyperparameters unpack(const Eigen::VectorXd& theta);
};

struct GpOptions {
  // Hyperparameter bounds (scikit-optimize: amplitude 0.01..1000, length scales 0.01..100).
  double min_amplitude = 0.01, max_amplitude = 1000.0;
  double min_length_scale = 0.01, max_length_scale = 100.0;
  double min_noise = 1e-10, max_noise = 1.0;  // standardised units; tiny floor so deterministic objectives are resolved finely
  int random_restarts = 2;
  int max_evaluations = 200;  // per local L-BFGS run
  // A local run stops once a step changes the log marginal likelihood by less than this (nats), besides
  // the relative 1e-9. Why: at 150 points the likelihood is ~900 and 1e-9 of it is 1e-6 nats; a
  // warm-started fit (hartmann6, 145 points) spent 29 evaluations (O(n^3) each, most of the fit) to gain
  // its last 5e-5 over its 10th. At 1e-4 it stops after ~15 with the same regret over 20 seeds as a pure
  // round-off change (docs/optimizer.md); 1e-3 (11) ended seeds 1-4 nearer 1e-6 than 2e-7. 0 (the
  // default): the relative tolerance alone. Off by default because 1e-4 changes every study's trajectory
  // (its proposals after the first warm fit): measured as no better than round-off in regret, and it moved
  // a hardware study's answer off the robot's lowest trial (HardwareModelTest.WithModelThreads...: a trial
  // 4% costlier); a faster fit is not worth a changed result without a study-level reason.
  double likelihood_tolerance = 0.0;

  // The box of GpHyperparameters::pack() for d dimensions, in log units.
  Eigen::VectorXd lower_bounds(int d) const;
  Eigen::VectorXd upper_bounds(int d) const;
  // A random restart of the hyperparameter search (pack() layout): uniform in the box, except the noise,
  // drawn only up to 0.1 (restarts at absurd noise levels waste the search).
  Eigen::VectorXd random_start(int d, std::mt19937_64& rng) const;
};

// Maximises f (value, and its gradient into the second argument when that is non-null) by NLopt L-BFGS
// within [lb, ub] from each start in turn, at most max_evaluations each, and returns the best point
// found (the earliest on ties; the first start if nothing finite was found). A non-finite value counts
// as -1e25 and a non-finite gradient entry as 0; NLopt's roundoff-limited stops keep the point reached.
// Each run stops when a step changes f by less than 1e-9 relative or, when absolute_tolerance > 0, less
// than that. The hyperparameter search of every GP here.
Eigen::VectorXd maximise_from_starts(const std::function<double(const Eigen::VectorXd&, Eigen::VectorXd*)>& f,
                                     const std::vector<Eigen::VectorXd>& starts, const Eigen::VectorXd& lb,
                                     const Eigen::VectorXd& ub, int max_evaluations, double absolute_tolerance = 0.0);

// K^-1 from the lower Cholesky factor L of K (K = L L^T), symmetric; for the likelihood's gradient.
Eigen::MatrixXd inverse_from_cholesky(const Eigen::MatrixXd& L);

// Cholesky factorisations of a covariance K that retry with growing jitter on the diagonal (K is
// modified: it ends with the jitter added), so that near-duplicate points never stop a model.
// For a likelihood evaluation: 1e-10, 1e-9, ... (below 1) added in turn; false when even that fails (the
// caller scores those hyperparameters as impossible).
bool cholesky_for_likelihood(Eigen::MatrixXd& K, Eigen::LLT<Eigen::MatrixXd>& llt);
// For a fitted model's factor: 1e-10 * max(1, mean diagonal), growing tenfold until it succeeds; returns
// the total jitter added.
double cholesky_with_jitter(Eigen::MatrixXd& K, Eigen::LLT<Eigen::MatrixXd>& llt);

// amplitude * Kernel (kernel.hpp) between the rows of A and the rows of B (no noise term): the covariance of
// every GP in this library (the cost GP, the fall classifier, both parts of the multi-fidelity model).
Eigen::MatrixXd kernel_matrix(const Eigen::MatrixXd& A, const Eigen::MatrixXd& B, const GpHyperparameters& h);

// The Kernel covariance of one point set with itself, kept with the kernel's slopes (kernel.hpp) so that a
// marginal likelihood's gradient with respect to the kernel's hyperparameters costs one more pass.
// Shared by GaussianProcess and MultiFidelityGP (whose two kernels are each one of these).
class KernelGram {
 public:
  KernelGram(const Eigen::MatrixXd& X, const GpHyperparameters& h);

  // amplitude * Kernel::value(r) over every pair (no noise term).
  const Eigen::MatrixXd& covariance() const { return K_; }

  // 0.5 * sum_ab W_ab dK_ab/dtheta for theta = log amplitude, then each log length scale (d + 1 values):
  // the kernel's share of dLML/dtheta when W = alpha alpha^T - K^-1 (W symmetric, same size as K).
  // Uses up the stored slopes (one n x n buffer fewer): call it at most once.
  Eigen::VectorXd half_trace_gradient(const Eigen::MatrixXd& W);

 private:
  double amp_ = 1.0;
  Eigen::MatrixXd Xs_;  // points divided by their length scales
  Eigen::ArrayXXd S_;   // Kernel::slope(r) of every pair
  Eigen::MatrixXd K_;
  bool used_ = false;
};

struct Prediction {
  double mean = 0.0;
  double std = 0.0;
};

// The posterior at a fixed set of candidates (columns of C), in a form that follows the model as points
// are appended to it (GaussianProcess::append_fixed, a batch's lies): with K = L L^T,
//   mean = k^T K^-1 y = V^T z,  var = amp - |V|^2 (per column),  V = L^-1 k(X, C),  z = L^-1 y,
// and appending rows to L only appends rows to V and z. So the next point of a batch costs the new rows
// (a kernel row and a product with V) instead of a fresh kernel and triangular solve over all points.
struct CandidatePosterior {
  Eigen::MatrixXd C;          // d x m candidates (unit cube)
  Eigen::MatrixXd V;          // rows x m: L^-1 k(X, C)
  Eigen::VectorXd z;          // L^-1 y_std, `rows` entries
  Eigen::VectorXd mean_std;   // standardised posterior means
  Eigen::VectorXd var_taken;  // |V.col(j)|^2 so far
  int rows = 0;               // model points covered
};

class GaussianProcess {
 public:
  explicit GaussianProcess(GpOptions options = {});

  // Fits to X (n x d, rows are points in the unit cube) and y (n). Hyperparameters are optimised when
  // `optimise` is true (starting from `start` if given, plus options.random_restarts random starts
  // drawn from `rng`); otherwise `start` is used as is.
  void fit(const Eigen::MatrixXd& X, const Eigen::VectorXd& y, bool optimise, std::mt19937_64& rng,
           const GpHyperparameters* start = nullptr);

  // Refactorises with the current hyperparameters after the data changed (used for constant-liar batches).
  void refit_fixed(const Eigen::MatrixXd& X, const Eigen::VectorXd& y);
  // Adds the rows of U (m x d) with targets y (m), hyperparameters and standardisation held, as
  // refit_fixed() on the extended data would, but by extending the Cholesky factor with a bordered block
  // (O(n^2 m + m^3) instead of O((n+m)^3) and no kernel of the old points with themselves): the working
  // model of a batch gains one fake result per pending or chosen point. Falls back to refit_fixed() when
  // the extension is not positive definite (it would need more jitter than the current factor has).
  // Returns false when it refactorised (the factor's earlier rows changed: incremental state built on
  // them, a CandidatePosterior, must be recomputed).
  bool append_fixed(const Eigen::MatrixXd& U, const Eigen::VectorXd& y);

  Prediction predict(const Eigen::VectorXd& x) const;
  // Mean and std with their gradients with respect to x.
  Prediction predict_with_gradient(const Eigen::VectorXd& x, Eigen::VectorXd* dmean, Eigen::VectorXd* dstd) const;
  // Means and stds for many points at once (columns of C): one triangular solve for all.
  void predict_many(const Eigen::MatrixXd& C, Eigen::VectorXd* mean, Eigen::VectorXd* std) const;
  // The same posterior as predict_many() (bit for bit), kept for extend().
  CandidatePosterior candidate_posterior(const Eigen::MatrixXd& C) const;
  // Brings `cp` to every current point, given that the factor's first cp.rows rows are those cp was
  // built with (only append_fixed() returning true since).
  void extend(CandidatePosterior& cp) const;
  // Means and stds (original units) of a candidate posterior covering every current point.
  void predict_candidates(const CandidatePosterior& cp, Eigen::VectorXd* mean, Eigen::VectorXd* std) const;

  // Log marginal likelihood of the standardised data at theta; fills grad (d/dtheta) when non-null.
  double log_marginal_likelihood(const Eigen::VectorXd& theta, Eigen::VectorXd* grad) const;

  const GpHyperparameters& hyperparameters() const { return hyper_; }
  bool fitted() const { return n_ > 0; }
  int num_points() const { return n_; }
  double jitter() const { return jitter_; }

 private:
  // Kernel matrix between the rows of A and the rows of B (without noise).
  Eigen::MatrixXd kernel(const Eigen::MatrixXd& A, const Eigen::MatrixXd& B, const GpHyperparameters& h) const;
  void factorise();
  Eigen::VectorXd solve(const Eigen::VectorXd& b) const;  // K^-1 b with the current factor

  GpOptions options_;
  GpHyperparameters hyper_;
  Eigen::MatrixXd X_;
  Eigen::VectorXd y_std_;  // standardised targets
  double y_mean_ = 0.0;
  double y_scale_ = 1.0;
  Eigen::MatrixXd L_;      // lower Cholesky factor of K + (noise + jitter) I (upper part zero)
  Eigen::VectorXd alpha_;  // K^-1 y_std
  double jitter_ = 0.0;
  int n_ = 0;
};

}  // namespace cpgmatch::bo
