#include "cpgmatch/bo/multi_fidelity_gp.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/QR>

namespace cpgmatch::bo {

Eigen::VectorXd MultiFidelityHyperparameters::pack() const {
  const Eigen::VectorXd s = simulation.pack(), d = discrepancy.pack();
  Eigen::VectorXd theta(s.size() + d.size() + 1);
  theta << s, d, rho;
  return theta;
}

MultiFidelityHyperparameters MultiFidelityHyperparameters::unpack(const Eigen::VectorXd& theta) {
  // 2 (d + 2) + 1 numbers.
  if (theta.size() < 7 || (theta.size() - 5) % 2 != 0) {
    throw std::invalid_argument("multi-fidelity hyperparameters: expected 2 d + 5 numbers, got " +
                                std::to_string(theta.size()));
  }
  const Eigen::Index block = (theta.size() - 1) / 2;
  MultiFidelityHyperparameters h;
  h.simulation = GpHyperparameters::unpack(theta.head(block));
  h.discrepancy = GpHyperparameters::unpack(theta.segment(block, block));
  h.rho = theta[theta.size() - 1];
  return h;
}

MultiFidelityGP::MultiFidelityGP(MultiFidelityOptions options) : options_(options) {}

Eigen::VectorXd MultiFidelityGP::lower_bounds(int d) const {
  Eigen::VectorXd lb(2 * d + 5);
  lb << options_.simulation.lower_bounds(d), options_.discrepancy.lower_bounds(d), options_.min_rho;
  return lb;
}

Eigen::VectorXd MultiFidelityGP::upper_bounds(int d) const {
  Eigen::VectorXd ub(2 * d + 5);
  ub << options_.simulation.upper_bounds(d), options_.discrepancy.upper_bounds(d), options_.max_rho;
  return ub;
}

Eigen::MatrixXd MultiFidelityGP::mean_basis(double rho) const {
  // Simulation rows [1, 0]: beta_s. Hardware rows [rho, 1]: rho beta_s + beta_d. Without hardware rows
  // beta_d is not identifiable: one column.
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(ns_ + nh_, nh_ > 0 ? 2 : 1);
  H.col(0).head(ns_).setOnes();
  if (nh_ > 0) {
    H.col(0).tail(nh_).setConstant(rho);
    H.col(1).tail(nh_).setOnes();
  }
  return H;
}

Eigen::MatrixXd MultiFidelityGP::joint_covariance(const MultiFidelityHyperparameters& h, const Eigen::MatrixXd& sim_gram,
                                                  const Eigen::MatrixXd& discrepancy_gram) const {
  Eigen::MatrixXd K = sim_gram;
  K.topRightCorner(ns_, nh_) *= h.rho;
  K.bottomLeftCorner(nh_, ns_) *= h.rho;
  K.bottomRightCorner(nh_, nh_) *= h.rho * h.rho;
  K.bottomRightCorner(nh_, nh_) += discrepancy_gram;
  K.diagonal().head(ns_).array() += std::exp(h.simulation.log_noise);
  K.diagonal().tail(nh_).array() += std::exp(h.discrepancy.log_noise);
  return K;
}

namespace {

// beta by generalised least squares, K^-1 (y - H beta) and log|K| from K's Cholesky factor.
struct Profile {
  Eigen::VectorXd beta;
  Eigen::VectorXd alpha;
  double quadratic = 0.0;  // (y - H beta)^T K^-1 (y - H beta)
};

Profile profile_mean(const Eigen::LLT<Eigen::MatrixXd>& llt, const Eigen::MatrixXd& H, const Eigen::VectorXd& y) {
  // With L^-1 H and L^-1 y, beta solves an ordinary least-squares problem (QR: no normal equations).
  const auto L = llt.matrixL();
  const Eigen::MatrixXd Hw = L.solve(H);
  const Eigen::VectorXd yw = L.solve(y);
  Profile p;
  p.beta = Hw.colPivHouseholderQr().solve(yw);
  const Eigen::VectorXd r = y - H * p.beta;
  p.alpha = llt.solve(r);
  p.quadratic = r.dot(p.alpha);
  return p;
}

}  // namespace

double MultiFidelityGP::log_marginal_likelihood(const Eigen::VectorXd& theta, Eigen::VectorXd* grad) const {
  const MultiFidelityHyperparameters h = MultiFidelityHyperparameters::unpack(theta);
  const int n = ns_ + nh_;
  const int d = static_cast<int>(X_.cols());
  KernelGram sim_gram(X_, h.simulation);
  KernelGram discrepancy_gram(X_.bottomRows(nh_), h.discrepancy);
  Eigen::MatrixXd K = joint_covariance(h, sim_gram.covariance(), discrepancy_gram.covariance());
  Eigen::LLT<Eigen::MatrixXd> llt;
  if (!cholesky_for_likelihood(K, llt)) {
    if (grad) grad->setZero(theta.size());
    return -1e25;
  }
  const Eigen::MatrixXd H = mean_basis(h.rho);
  const Profile p = profile_mean(llt, H, y_std_);
  const Eigen::MatrixXd& L = llt.matrixLLT();
  const double log_det = 2.0 * L.diagonal().array().log().sum();
  const double lml = -0.5 * p.quadratic - 0.5 * log_det - 0.5 * n * std::log(2.0 * std::numbers::pi);
  if (grad) {
    grad->setZero(theta.size());
    // At the GLS beta the likelihood is stationary in beta, so each derivative is the partial one with
    // beta held: 0.5 sum(W .* dK/dtheta) + alpha^T dmean/dtheta, W = alpha alpha^T - K^-1.
    const Eigen::MatrixXd W = p.alpha * p.alpha.transpose() - inverse_from_cholesky(L);
    const auto Wsh = W.topRightCorner(ns_, nh_);
    const auto Whh = W.bottomRightCorner(nh_, nh_);
    const Eigen::MatrixXd& Ks = sim_gram.covariance();
    // rho: dK/drho is K_s on the cross blocks and 2 rho K_s on the hardware block; the hardware rows'
    // mean rho beta_s + beta_d moves by beta_s.
    double d_rho = (Wsh.array() * Ks.topRightCorner(ns_, nh_).array()).sum() +
                   h.rho * (Whh.array() * Ks.bottomRightCorner(nh_, nh_).array()).sum();
    if (nh_ > 0) d_rho += p.beta[0] * p.alpha.tail(nh_).sum();
    // The simulation kernel enters K scaled blockwise by [1, rho; rho, rho^2]: its gradient is that of
    // a plain Gram against W scaled the same way.
    Eigen::MatrixXd Ws = W;
    Ws.topRightCorner(ns_, nh_) *= h.rho;
    Ws.bottomLeftCorner(nh_, ns_) *= h.rho;
    Ws.bottomRightCorner(nh_, nh_) *= h.rho * h.rho;
    const Eigen::VectorXd g_sim = sim_gram.half_trace_gradient(Ws);
    grad->head(d + 1) = g_sim;
    (*grad)[d + 1] = 0.5 * std::exp(h.simulation.log_noise) * W.topLeftCorner(ns_, ns_).trace();
    if (nh_ > 0) {
      const Eigen::VectorXd g_disc = discrepancy_gram.half_trace_gradient(Whh);
      grad->segment(d + 2, d + 1) = g_disc;
      (*grad)[2 * d + 3] = 0.5 * std::exp(h.discrepancy.log_noise) * Whh.trace();
    }
    (*grad)[2 * d + 4] = d_rho;
  }
  return lml;
}

MultiFidelityHyperparameters MultiFidelityGP::two_stage_start(std::mt19937_64& rng) const {
  const int d = static_cast<int>(X_.cols());
  // Stage 1: the simulation alone (already standardised, so the GP's own standardisation is the identity
  // up to round-off and its hyperparameters are in this model's units).
  GaussianProcess sim(options_.simulation);
  sim.fit(X_.topRows(ns_), y_std_.head(ns_), /*optimise=*/true, rng);
  MultiFidelityHyperparameters h;
  h.simulation = sim.hyperparameters();
  h.discrepancy.log_length_scales = Eigen::VectorXd::Zero(d);
  h.discrepancy.log_noise = std::log(1e-2);
  double discrepancy_variance = options_.prior_discrepancy_amplitude;
  h.rho = 1.0;
  if (nh_ > 0) {
    // Stage 2: yh ~ rho mean_s(xh) + beta_d by least squares; the residuals' spread sizes the discrepancy.
    Eigen::VectorXd m(nh_);
    for (int i = 0; i < nh_; ++i) m[i] = sim.predict(X_.row(ns_ + i).transpose()).mean;
    const Eigen::VectorXd yh = y_std_.tail(nh_);
    const double m_mean = m.mean(), y_mean = yh.mean();
    const double m_var = (m.array() - m_mean).square().sum();
    if (nh_ >= 2 && m_var > 1e-12) h.rho = (m.array() - m_mean).matrix().dot((yh.array() - y_mean).matrix()) / m_var;
    h.rho = std::clamp(h.rho, options_.min_rho, options_.max_rho);
    const Eigen::ArrayXd residual = yh.array() - h.rho * m.array();
    discrepancy_variance = (residual - residual.mean()).square().mean();
  }
  h.discrepancy.log_amplitude =
      std::log(std::clamp(discrepancy_variance, options_.discrepancy.min_amplitude, options_.discrepancy.max_amplitude));
  return h;
}

void MultiFidelityGP::fit(const Eigen::MatrixXd& Xs, const Eigen::VectorXd& ys, const Eigen::MatrixXd& Xh,
                          const Eigen::VectorXd& yh, bool optimise, std::mt19937_64& rng,
                          const MultiFidelityHyperparameters* start) {
  if (Xs.rows() != ys.size() || Xh.rows() != yh.size()) {
    throw std::invalid_argument("MultiFidelityGP::fit: points and values differ in number");
  }
  if (Xs.rows() < 2) throw std::invalid_argument("MultiFidelityGP::fit: needs at least 2 simulation points");
  if (Xh.rows() > 0 && Xh.cols() != Xs.cols()) {
    throw std::invalid_argument("MultiFidelityGP::fit: simulation and hardware points differ in dimension");
  }
  const int d = static_cast<int>(Xs.cols());
  if (start && start->simulation.log_length_scales.size() != d) start = nullptr;
  if (!optimise && !start) throw std::invalid_argument("MultiFidelityGP::fit: fixed hyperparameters need a start");
  ns_ = static_cast<int>(Xs.rows());
  nh_ = static_cast<int>(Xh.rows());
  X_.resize(ns_ + nh_, d);
  X_.topRows(ns_) = Xs;
  X_.bottomRows(nh_) = Xh;
  // One affine map for both sources (the simulation's), so that rho is a ratio of costs.
  y_mean_ = ys.mean();
  const double var = (ys.array() - y_mean_).square().sum() / ns_;
  y_scale_ = var > 1e-300 ? std::sqrt(var) : 1.0;
  y_std_.resize(ns_ + nh_);
  y_std_.head(ns_) = (ys.array() - y_mean_) / y_scale_;
  y_std_.tail(nh_) = (yh.array() - y_mean_) / y_scale_;

  if (optimise) {
    const Eigen::VectorXd lb = lower_bounds(d), ub = upper_bounds(d);
    std::vector<Eigen::VectorXd> starts;
    if (start) starts.push_back(start->pack().cwiseMax(lb).cwiseMin(ub));
    const MultiFidelityHyperparameters staged = two_stage_start(rng);
    starts.push_back(staged.pack().cwiseMax(lb).cwiseMin(ub));
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    for (int k = 0; k < options_.simulation.random_restarts; ++k) {
      Eigen::VectorXd t(2 * d + 5);
      t << options_.simulation.random_start(d, rng), options_.discrepancy.random_start(d, rng),
          options_.min_rho + unit(rng) * (options_.max_rho - options_.min_rho);
      // Without hardware points rho and the discrepancy do not enter the likelihood (zero gradient): keep
      // the two-stage values rather than random ones.
      if (nh_ == 0) t.tail(d + 3) = starts.back().tail(d + 3);
      starts.push_back(t);
    }
    hyper_ = MultiFidelityHyperparameters::unpack(maximise_from_starts(
        [this](const Eigen::VectorXd& theta, Eigen::VectorXd* grad) { return log_marginal_likelihood(theta, grad); },
        starts, lb, ub, options_.simulation.max_evaluations));
  } else {
    hyper_ = *start;
  }
  factorise();
}

void MultiFidelityGP::factorise() {
  const Eigen::MatrixXd hw = X_.bottomRows(nh_);
  Eigen::MatrixXd K = joint_covariance(hyper_, kernel_matrix(X_, X_, hyper_.simulation),
                                       kernel_matrix(hw, hw, hyper_.discrepancy));
  Eigen::LLT<Eigen::MatrixXd> llt;
  jitter_ = cholesky_with_jitter(K, llt);
  L_ = llt.matrixL();
  const Profile p = profile_mean(llt, mean_basis(hyper_.rho), y_std_);
  beta_.setZero();
  beta_.head(p.beta.size()) = p.beta;
  alpha_ = p.alpha;
}

Eigen::MatrixXd MultiFidelityGP::cross_covariance(Target t, const Eigen::MatrixXd& C) const {
  const double rho = hyper_.rho;
  const Eigen::MatrixXd points = C.transpose();
  Eigen::MatrixXd k(ns_ + nh_, C.cols());
  if (t == Target::kDiscrepancy) {
    k.topRows(ns_).setZero();  // the discrepancy is independent of the simulation
  } else {
    k = kernel_matrix(X_, points, hyper_.simulation);
    // cov(sim(x), y_sim) = k_s, cov(sim(x), y_hw) = rho k_s; hardware(x) = rho sim(x) + ... scales both by rho.
    k.bottomRows(nh_) *= rho;
    if (t == Target::kHardware) k *= rho;
  }
  if (t != Target::kSimulation && nh_ > 0) {
    const Eigen::MatrixXd kd = kernel_matrix(X_.bottomRows(nh_), points, hyper_.discrepancy);
    if (t == Target::kDiscrepancy) k.bottomRows(nh_) = kd;
    else k.bottomRows(nh_) += kd;
  }
  return k;
}

double MultiFidelityGP::prior_variance(Target t) const {
  const double s = std::exp(hyper_.simulation.log_amplitude), d = std::exp(hyper_.discrepancy.log_amplitude);
  switch (t) {
    case Target::kSimulation: return s;
    case Target::kHardware: return hyper_.rho * hyper_.rho * s + d;
    case Target::kDiscrepancy: return d;
  }
  return s;
}

double MultiFidelityGP::prior_mean(Target t) const {
  switch (t) {
    case Target::kSimulation: return beta_[0];
    case Target::kHardware: return hyper_.rho * beta_[0] + beta_[1];
    case Target::kDiscrepancy: return beta_[1];
  }
  return beta_[0];
}

void MultiFidelityGP::predict(Target t, const Eigen::MatrixXd& C, Eigen::VectorXd* mean, Eigen::VectorXd* std) const {
  Eigen::MatrixXd V = cross_covariance(t, C);
  const Eigen::VectorXd mean_std = (V.transpose() * alpha_).array() + prior_mean(t);
  L_.triangularView<Eigen::Lower>().solveInPlace(V);
  const double prior = prior_variance(t);
  const Eigen::ArrayXd var = (prior - V.colwise().squaredNorm().transpose().array()).max(1e-12 * prior);
  // Back to the caller's units. The simulation's offset y_mean enters hardware(x) once and the
  // discrepancy hardware - rho sim as (1 - rho) y_mean: h = y_mean + scale h', s = y_mean + scale s'.
  const double offset = t == Target::kDiscrepancy ? (1.0 - hyper_.rho) * y_mean_ : y_mean_;
  *mean = (mean_std.array() * y_scale_ + offset).matrix();
  *std = (y_scale_ * var.sqrt()).matrix();
}

namespace {
Prediction first(const Eigen::VectorXd& mean, const Eigen::VectorXd& std) { return {mean[0], std[0]}; }
}  // namespace

Prediction MultiFidelityGP::predict_hardware(const Eigen::VectorXd& x) const {
  Eigen::VectorXd m, s;
  predict(Target::kHardware, x, &m, &s);
  return first(m, s);
}

Prediction MultiFidelityGP::predict_simulation(const Eigen::VectorXd& x) const {
  Eigen::VectorXd m, s;
  predict(Target::kSimulation, x, &m, &s);
  return first(m, s);
}

Prediction MultiFidelityGP::predict_discrepancy(const Eigen::VectorXd& x) const {
  Eigen::VectorXd m, s;
  predict(Target::kDiscrepancy, x, &m, &s);
  return first(m, s);
}

void MultiFidelityGP::predict_hardware_many(const Eigen::MatrixXd& C, Eigen::VectorXd* mean, Eigen::VectorXd* std) const {
  predict(Target::kHardware, C, mean, std);
}

double MultiFidelityGP::constant_discrepancy() const { return (1.0 - hyper_.rho) * y_mean_ + y_scale_ * beta_[1]; }

}  // namespace cpgmatch::bo
