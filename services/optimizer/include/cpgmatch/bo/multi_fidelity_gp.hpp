// One Gaussian-process model over two sources of the same cost: a cheap simulation and the expensive robot.
// Kennedy & O'Hagan's autoregressive co-kriging (Biometrika 2000; Forrester, Sobester & Keane 2007):
//
//   sim(x)      = beta_s + s(x),                      s ~ GP(0, k_s)
//   hardware(x) = rho * sim(x) + beta_d + d(x),       d ~ GP(0, k_d), independent of s
//
// with k_s and k_d each amplitude * Matern52 (one length scale per dimension, as the cost GP) and a
// white noise per source (the sim's in k_s's hyperparameters, the robot's in k_d's). So over the stacked
// observations [y_sim; y_hw] the covariance is
//
//   K = [ K_s(Xs, Xs) + n_s I      rho K_s(Xs, Xh)                      ]
//       [ rho K_s(Xh, Xs)          rho^2 K_s(Xh, Xh) + K_d(Xh, Xh) + n_h I ]
//
// and the mean is H beta with H's rows [1, 0] (sim) and [rho, 1] (hardware). What is learned, all by
// maximising the joint log marginal likelihood (analytic gradients, NLopt L-BFGS, bounds):
//   - rho, how hardware scales with simulation;
//   - the simulation kernel's amplitude, length scales and noise;
//   - the discrepancy's amplitude and length scales (how large and how smooth the reality gap is) and the
//     robot's noise;
// while beta = (beta_s, beta_d) is profiled out by generalised least squares at every likelihood
// evaluation (its gradient term vanishes there; rho's effect through H counts). beta_d is the constant
// part of the reality gap, d(x) its smooth part.
//
// Units: both sources are standardised with the simulation's mean and standard deviation (one affine map,
// so rho keeps its meaning); every prediction is returned in the caller's units. Predictions are of the
// latent functions (no noise), like GaussianProcess; they leave out beta's own uncertainty.
//
// Numerics as GaussianProcess: inputs in the unit cube, Cholesky retried with growing jitter, so a
// posterior is never NaN. With no hardware observation the model is the simulation GP with rho = 1,
// beta_d = 0 and the discrepancy at its starting hyperparameters (hardware is believed to be the
// simulation, up to a discrepancy of that prior size).
#pragma once

#include <random>

#include <Eigen/Core>

#include "cpgmatch/bo/gaussian_process.hpp"

namespace cpgmatch::bo {

struct MultiFidelityHyperparameters {
  GpHyperparameters simulation;   // k_s and the simulation's noise
  GpHyperparameters discrepancy;  // k_d and the robot's noise
  double rho = 1.0;

  // [simulation.pack(), discrepancy.pack(), rho]: 2 d + 5 numbers.
  Eigen::VectorXd pack() const;
  // Throws std::invalid_argument unless theta.size() == 2 d + 5 for some d >= 1.
  static MultiFidelityHyperparameters unpack(const Eigen::VectorXd& theta);
};

struct MultiFidelityOptions {
  GpOptions simulation;  // bounds, random restarts and L-BFGS budget of the joint fit come from here
  // The discrepancy may be far smaller than the simulation's spread (hardware = rho sim + a constant
  // has none at all), so its amplitude may go lower than the cost GP's 0.01 (standardised units).
  GpOptions discrepancy = [] {
    GpOptions o;
    o.min_amplitude = 1e-6;
    return o;
  }();
  // rho's bounds. A robot whose cost falls where the simulation's rises (rho < 0) would make the
  // simulation useless rather than informative; a rho above 3 would say the robot amplifies every
  // simulated difference threefold, beyond any gap we model. Both are errors to look for, not to fit.
  double min_rho = -1.0, max_rho = 3.0;
  // Starting size of the discrepancy (standardised units) while no hardware observation says otherwise.
  double prior_discrepancy_amplitude = 0.1;
};

class MultiFidelityGP {
 public:
  explicit MultiFidelityGP(MultiFidelityOptions options = {});

  // Fits to the simulation's (Xs: ns x d in the unit cube, ys) and the robot's observations (Xh, yh).
  // Needs ns >= 2; nh may be 0. With `optimise`, every hyperparameter and rho maximise the joint
  // likelihood from `start` (if given), from a two-stage start (a simulation GP alone, then rho and
  // beta_d by least squares of yh on its mean) and from options.simulation.random_restarts random
  // starts drawn from `rng`; without, `start` (required then) is used as is. Throws std::invalid_argument
  // for inconsistent sizes.
  void fit(const Eigen::MatrixXd& Xs, const Eigen::VectorXd& ys, const Eigen::MatrixXd& Xh, const Eigen::VectorXd& yh,
           bool optimise, std::mt19937_64& rng, const MultiFidelityHyperparameters* start = nullptr);

  // Posteriors at x (unit cube), in the caller's units.
  Prediction predict_hardware(const Eigen::VectorXd& x) const;
  Prediction predict_simulation(const Eigen::VectorXd& x) const;
  // The reality gap hardware(x) - rho sim(x) = beta_d + d(x).
  Prediction predict_discrepancy(const Eigen::VectorXd& x) const;
  // Hardware means and stds at the columns of C (one triangular solve for all).
  void predict_hardware_many(const Eigen::MatrixXd& C, Eigen::VectorXd* mean, Eigen::VectorXd* std) const;

  // Joint log marginal likelihood (beta profiled out) of the standardised data at theta (pack() layout);
  // fills grad when non-null.
  double log_marginal_likelihood(const Eigen::VectorXd& theta, Eigen::VectorXd* grad) const;

  const MultiFidelityHyperparameters& hyperparameters() const { return hyper_; }
  double rho() const { return hyper_.rho; }
  // beta_d in the caller's units: the constant part of hardware(x) - rho sim(x).
  double constant_discrepancy() const;
  bool fitted() const { return ns_ > 0; }
  int num_simulation() const { return ns_; }
  int num_hardware() const { return nh_; }
  double jitter() const { return jitter_; }

 private:
  enum class Target { kSimulation, kHardware, kDiscrepancy };
  // Covariances of target(x) with the stacked observations (N x m for the m columns of C), its prior
  // variance and its standardised prior mean.
  Eigen::MatrixXd cross_covariance(Target t, const Eigen::MatrixXd& C) const;
  double prior_variance(Target t) const;
  double prior_mean(Target t) const;
  void predict(Target t, const Eigen::MatrixXd& C, Eigen::VectorXd* mean, Eigen::VectorXd* std) const;
  // Joint covariance (noise and jitter included), and the simulation kernel's Gram over all points.
  Eigen::MatrixXd joint_covariance(const MultiFidelityHyperparameters& h, const Eigen::MatrixXd& sim_gram,
                                   const Eigen::MatrixXd& discrepancy_gram) const;
  Eigen::MatrixXd mean_basis(double rho) const;  // H: N x (nh > 0 ? 2 : 1)
  MultiFidelityHyperparameters two_stage_start(std::mt19937_64& rng) const;
  void factorise();
  Eigen::VectorXd lower_bounds(int d) const;
  Eigen::VectorXd upper_bounds(int d) const;

  MultiFidelityOptions options_;
  MultiFidelityHyperparameters hyper_;
  Eigen::MatrixXd X_;      // simulation rows, then hardware rows (unit cube)
  Eigen::VectorXd y_std_;  // both sources standardised with the simulation's mean and scale
  double y_mean_ = 0.0, y_scale_ = 1.0;
  int ns_ = 0, nh_ = 0;
  Eigen::MatrixXd L_;      // lower Cholesky factor of the joint covariance
  Eigen::VectorXd alpha_;  // K^-1 (y - H beta)
  Eigen::Vector2d beta_ = Eigen::Vector2d::Zero();  // standardised beta_s, beta_d
  double jitter_ = 0.0;
};

}  // namespace cpgmatch::bo
