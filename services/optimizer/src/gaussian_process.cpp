#include "cpgmatch/bo/gaussian_process.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>

#include <nlopt.hpp>

namespace cpgmatch::bo {

Eigen::MatrixXd inverse_from_cholesky(const Eigen::MatrixXd& L) {
  // By column blocks of width b: L^-1 is lower triangular, so block J's columns are zero above row j0 and
  // need only the trailing factor L[j0:, j0:]; then the lower half of K^-1 = L^-T L^-1, whose entry (i, j),
  // i >= j, sums L^-1(k, i) L^-1(k, j) over k >= i, so block J's rows i >= j0 need only rows k >= j0.
  // About n^3/2 multiply-adds instead of 4n^3/3 (full solve against the identity, then a full product).
  const Eigen::Index n = L.rows();
  constexpr Eigen::Index kBlock = 32;
  Eigen::MatrixXd Linv = Eigen::MatrixXd::Zero(n, n);
  for (Eigen::Index j0 = 0; j0 < n; j0 += kBlock) {
    const Eigen::Index b = std::min(kBlock, n - j0), m = n - j0;
    auto block = Linv.block(j0, j0, m, b);
    block.topRows(b).setIdentity();
    L.block(j0, j0, m, m).triangularView<Eigen::Lower>().solveInPlace(block);
  }
  Eigen::MatrixXd Kinv(n, n);
  for (Eigen::Index j0 = 0; j0 < n; j0 += kBlock) {
    const Eigen::Index b = std::min(kBlock, n - j0), m = n - j0;
    Kinv.block(j0, j0, m, b).noalias() = Linv.block(j0, j0, m, m).transpose() * Linv.block(j0, j0, m, b);
  }
  Kinv.triangularView<Eigen::StrictlyUpper>() = Kinv.transpose();
  return Kinv;
}

Eigen::VectorXd GpHyperparameters::pack() const {
  Eigen::VectorXd theta(log_length_scales.size() + 2);
  theta[0] = log_amplitude;
  theta.segment(1, log_length_scales.size()) = log_length_scales;
  theta[theta.size() - 1] = log_noise;
  return theta;
}

GpHyperparameters GpHyperparameters::unpack(const Eigen::VectorXd& theta) {
  GpHyperparameters h;
  h.log_amplitude = theta[0];
  h.log_length_scales = theta.segment(1, theta.size() - 2);
  h.log_noise = theta[theta.size() - 1];
  return h;
}

GaussianProcess::GaussianProcess(GpOptions options) : options_(options) {}

bool cholesky_for_likelihood(Eigen::MatrixXd& K, Eigen::LLT<Eigen::MatrixXd>& llt) {
  llt.compute(K);
  double jitter = 1e-10;
  while (llt.info() != Eigen::Success && jitter < 1.0) {
    K.diagonal().array() += jitter;
    llt.compute(K);
    jitter *= 10.0;
  }
  return llt.info() == Eigen::Success;
}

double cholesky_with_jitter(Eigen::MatrixXd& K, Eigen::LLT<Eigen::MatrixXd>& llt) {
  llt.compute(K);
  double total = 0.0;
  double add = 1e-10 * std::max(1.0, K.diagonal().mean());
  while (llt.info() != Eigen::Success) {
    K.diagonal().array() += add;
    total += add;
    add *= 10.0;
    llt.compute(K);
  }
  return total;
}

Eigen::MatrixXd kernel_matrix(const Eigen::MatrixXd& A, const Eigen::MatrixXd& B, const GpHyperparameters& h) {
  const Eigen::ArrayXd inv_l = (-h.log_length_scales.array()).exp();
  const Eigen::MatrixXd As = A * inv_l.matrix().asDiagonal();
  const Eigen::MatrixXd Bs = B * inv_l.matrix().asDiagonal();
  const Eigen::VectorXd a2 = As.rowwise().squaredNorm();
  const Eigen::VectorXd b2 = Bs.rowwise().squaredNorm();
  // Every step in place in the one result matrix: for the acquisition search's 1000 candidates it is
  // ~1 MB, and each further temporary of that size costs a pass over memory and, from a fresh
  // allocation, its page faults (as much again as the arithmetic in a small process).
  Eigen::MatrixXd K(A.rows(), B.rows());
  K.noalias() = -2.0 * As * Bs.transpose();
  K.colwise() += a2;
  K.rowwise() += b2.transpose();
  const double amp = std::exp(h.log_amplitude);
  K.array() = K.array().max(0.0).sqrt();
  K.array() = amp * Kernel::value(K.array());
  return K;
}

Eigen::MatrixXd GaussianProcess::kernel(const Eigen::MatrixXd& A, const Eigen::MatrixXd& B,
                                        const GpHyperparameters& h) const {
  return kernel_matrix(A, B, h);
}

KernelGram::KernelGram(const Eigen::MatrixXd& X, const GpHyperparameters& h) {
  const Eigen::Index n = X.rows(), d = X.cols();
  amp_ = std::exp(h.log_amplitude);
  const Eigen::ArrayXd inv_l = (-h.log_length_scales.array()).exp();
  Xs_ = X * inv_l.matrix().asDiagonal();
  // Scaled distances r once per pair: the kernel and every length-scale gradient use them (the likelihood
  // is most of a hyperparameter fit). Per dimension, as whole-matrix array operations (vectorised; the
  // pairwise differences themselves, not a Gram matrix, so close points keep their accuracy).
  Eigen::ArrayXXd R = Eigen::ArrayXXd::Zero(n, n);
  for (Eigen::Index b = 0; b < n; ++b) {
    for (Eigen::Index j = 0; j < d; ++j) R.col(b) += (Xs_.col(j).array() - Xs_(b, j)).square();
  }
  R = R.sqrt();
  Eigen::ArrayXXd value(n, n);
  Kernel::value_and_slope(R, value, S_);
  K_ = (amp_ * value).matrix();
}

Eigen::VectorXd KernelGram::half_trace_gradient(const Eigen::MatrixXd& W) {
  if (used_) throw std::logic_error("KernelGram::half_trace_gradient called twice");
  used_ = true;
  const Eigen::Index n = Xs_.rows(), d = Xs_.cols();
  Eigen::VectorXd grad(d + 1);
  grad[0] = 0.5 * (W.array() * K_.array()).sum();
  // dk/dlog(l_j) = amp * slope(r) * (x_j - x'_j)^2 / l_j^2 (kernel.hpp). The common factor overwrites the
  // slopes (not needed any more). Column b's terms for every dimension while the column is in cache; each
  // dimension's sum still runs over b in order.
  Eigen::ArrayXXd& common = S_;
  common = amp_ * S_ * W.array();
  Eigen::VectorXd sums = Eigen::VectorXd::Zero(d);
  for (Eigen::Index b = 0; b < n; ++b) {
    for (Eigen::Index j = 0; j < d; ++j) sums[j] += (common.col(b) * (Xs_.col(j).array() - Xs_(b, j)).square()).sum();
  }
  grad.tail(d) = 0.5 * sums;  // symmetric; zero on the diagonal
  return grad;
}

Eigen::VectorXd GpOptions::lower_bounds(int d) const {
  Eigen::VectorXd lb(d + 2);
  lb[0] = std::log(min_amplitude);
  lb.segment(1, d).setConstant(std::log(min_length_scale));
  lb[d + 1] = std::log(min_noise);
  return lb;
}

Eigen::VectorXd GpOptions::upper_bounds(int d) const {
  Eigen::VectorXd ub(d + 2);
  ub[0] = std::log(max_amplitude);
  ub.segment(1, d).setConstant(std::log(max_length_scale));
  ub[d + 1] = std::log(max_noise);
  return ub;
}

Eigen::VectorXd GpOptions::random_start(int d, std::mt19937_64& rng) const {
  const Eigen::VectorXd lb = lower_bounds(d), ub = upper_bounds(d);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  Eigen::VectorXd t(d + 2);
  for (int i = 0; i < d + 2; ++i) t[i] = lb[i] + unit(rng) * (ub[i] - lb[i]);
  t[d + 1] = std::log(min_noise) + unit(rng) * (std::log(1e-1) - std::log(min_noise));
  return t;
}

Eigen::VectorXd maximise_from_starts(const std::function<double(const Eigen::VectorXd&, Eigen::VectorXd*)>& f,
                                     const std::vector<Eigen::VectorXd>& starts, const Eigen::VectorXd& lb,
                                     const Eigen::VectorXd& ub, int max_evaluations, double absolute_tolerance) {
  using Function = std::function<double(const Eigen::VectorXd&, Eigen::VectorXd*)>;
  auto objective = [](unsigned size, const double* x, double* g, void* data) -> double {
    const Function& function = *static_cast<const Function*>(data);
    const Eigen::Map<const Eigen::VectorXd> theta(x, size);
    Eigen::VectorXd grad;
    const double v = function(theta, g ? &grad : nullptr);
    if (g) for (unsigned i = 0; i < size; ++i) g[i] = std::isfinite(grad[i]) ? grad[i] : 0.0;
    return std::isfinite(v) ? v : -1e25;
  };
  double best = -std::numeric_limits<double>::infinity();
  Eigen::VectorXd best_theta = starts.front();
  for (const auto& s : starts) {
    nlopt::opt opt(nlopt::LD_LBFGS, static_cast<unsigned>(lb.size()));
    opt.set_lower_bounds(std::vector<double>(lb.data(), lb.data() + lb.size()));
    opt.set_upper_bounds(std::vector<double>(ub.data(), ub.data() + ub.size()));
    opt.set_max_objective(objective, const_cast<void*>(static_cast<const void*>(&f)));
    opt.set_maxeval(max_evaluations);
    opt.set_ftol_rel(1e-9);
    if (absolute_tolerance > 0.0) opt.set_ftol_abs(absolute_tolerance);
    std::vector<double> x(s.data(), s.data() + s.size());
    double value = -std::numeric_limits<double>::infinity();
    try {
      opt.optimize(x, value);
    } catch (const std::exception&) {
      // NLopt throws on roundoff-limited stops; x still holds the best point it found.
      value = f(Eigen::Map<Eigen::VectorXd>(x.data(), x.size()), nullptr);
    }
    if (std::isfinite(value) && value > best) {
      best = value;
      best_theta = Eigen::Map<Eigen::VectorXd>(x.data(), x.size());
    }
  }
  return best_theta;
}

double GaussianProcess::log_marginal_likelihood(const Eigen::VectorXd& theta, Eigen::VectorXd* grad) const {
  const GpHyperparameters h = GpHyperparameters::unpack(theta);
  const int n = static_cast<int>(X_.rows());
  const int d = static_cast<int>(X_.cols());
  KernelGram gram(X_, h);
  Eigen::MatrixXd K = gram.covariance();
  const double noise = std::exp(h.log_noise);
  K.diagonal().array() += noise;
  Eigen::LLT<Eigen::MatrixXd> llt;
  if (!cholesky_for_likelihood(K, llt)) {
    if (grad) grad->setZero(theta.size());
    return -1e25;
  }
  const Eigen::VectorXd alpha = llt.solve(y_std_);
  const Eigen::MatrixXd& L = llt.matrixLLT();
  const double log_det = 2.0 * L.diagonal().array().log().sum();
  const double lml = -0.5 * y_std_.dot(alpha) - 0.5 * log_det - 0.5 * n * std::log(2.0 * std::numbers::pi);
  if (grad) {
    grad->resize(theta.size());
    // dLML/dtheta_j = 0.5 * sum(W .* dK/dtheta_j), W = alpha alpha^T - K^-1, with K^-1 from the Cholesky
    // factor by triangular blocks (inverse_from_cholesky: about half the work of a full triangular
    // solve against the identity and a product of full matrices).
    const Eigen::MatrixXd W = alpha * alpha.transpose() - inverse_from_cholesky(L);
    const Eigen::VectorXd kernel_grad = gram.half_trace_gradient(W);
    (*grad)[0] = kernel_grad[0];
    grad->segment(1, d) = kernel_grad.tail(d);
    (*grad)[d + 1] = 0.5 * noise * W.trace();
  }
  return lml;
}

void GaussianProcess::fit(const Eigen::MatrixXd& X, const Eigen::VectorXd& y, bool optimise, std::mt19937_64& rng,
                          const GpHyperparameters* start) {
  X_ = X;
  n_ = static_cast<int>(X.rows());
  const int d = static_cast<int>(X.cols());
  y_mean_ = y.mean();
  const double var = n_ > 1 ? (y.array() - y_mean_).square().sum() / n_ : 0.0;
  y_scale_ = var > 1e-300 ? std::sqrt(var) : 1.0;
  y_std_ = (y.array() - y_mean_) / y_scale_;

  GpHyperparameters initial;
  if (start && start->log_length_scales.size() == d) {
    initial = *start;
  } else {
    initial.log_amplitude = 0.0;
    initial.log_length_scales = Eigen::VectorXd::Zero(d);  // length scale 1, as scikit-optimize starts
    initial.log_noise = std::log(1e-2);
  }
  hyper_ = initial;

  if (optimise && n_ >= 2) {
    const Eigen::VectorXd lb = options_.lower_bounds(d), ub = options_.upper_bounds(d);
    std::vector<Eigen::VectorXd> starts{initial.pack().cwiseMax(lb).cwiseMin(ub)};
    for (int k = 0; k < options_.random_restarts; ++k) starts.push_back(options_.random_start(d, rng));
    const Eigen::VectorXd best_theta = maximise_from_starts(
        [this](const Eigen::VectorXd& theta, Eigen::VectorXd* grad) { return log_marginal_likelihood(theta, grad); },
        starts, lb, ub, options_.max_evaluations, options_.likelihood_tolerance);
    hyper_ = GpHyperparameters::unpack(best_theta);
  }
  factorise();
}

void GaussianProcess::refit_fixed(const Eigen::MatrixXd& X, const Eigen::VectorXd& y) {
  X_ = X;
  n_ = static_cast<int>(X.rows());
  y_std_ = (y.array() - y_mean_) / y_scale_;  // keep the standardisation of the last full fit
  factorise();
}

bool GaussianProcess::append_fixed(const Eigen::MatrixXd& U, const Eigen::VectorXd& y) {
  const int m = static_cast<int>(U.rows());
  if (m == 0) return true;
  const int n = n_;
  Eigen::MatrixXd X(n + m, X_.cols());
  X << X_, U;
  Eigen::VectorXd y_std(n + m);
  y_std << y_std_, (y.array() - y_mean_) / y_scale_;  // what refit_fixed() computes from the same targets
  auto refactorise = [&] {
    X_ = std::move(X);
    n_ = n + m;
    y_std_ = std::move(y_std);
    factorise();
    return false;
  };
  if (n == 0) return refactorise();
  // [K11 K12; K21 K22] = [L 0; B^T C][L^T B; 0 C^T]: B = L^-1 K12, C C^T = K22 - B^T B.
  const Eigen::MatrixXd B = L_.triangularView<Eigen::Lower>().solve(kernel(X_, U, hyper_));
  Eigen::MatrixXd S = kernel(U, U, hyper_);
  S.diagonal().array() += std::exp(hyper_.log_noise) + jitter_;
  S.noalias() -= B.transpose() * B;
  Eigen::LLT<Eigen::MatrixXd> schur(S);
  if (schur.info() != Eigen::Success) return refactorise();
  Eigen::MatrixXd L(n + m, n + m);
  L.topLeftCorner(n, n) = L_;
  L.topRightCorner(n, m).setZero();
  L.bottomLeftCorner(m, n) = B.transpose();
  L.bottomRightCorner(m, m) = schur.matrixL();
  L_ = std::move(L);
  X_ = std::move(X);
  n_ = n + m;
  y_std_ = std::move(y_std);
  alpha_ = solve(y_std_);
  return true;
}

Eigen::VectorXd GaussianProcess::solve(const Eigen::VectorXd& b) const {
  Eigen::VectorXd x = b;
  L_.triangularView<Eigen::Lower>().solveInPlace(x);
  L_.transpose().triangularView<Eigen::Upper>().solveInPlace(x);
  return x;
}

void GaussianProcess::factorise() {
  Eigen::MatrixXd K = kernel(X_, X_, hyper_);
  K.diagonal().array() += std::exp(hyper_.log_noise);
  Eigen::LLT<Eigen::MatrixXd> llt;
  jitter_ = cholesky_with_jitter(K, llt);
  L_ = llt.matrixL();
  alpha_ = solve(y_std_);
}

Prediction GaussianProcess::predict(const Eigen::VectorXd& x) const {
  return predict_with_gradient(x, nullptr, nullptr);
}

Prediction GaussianProcess::predict_with_gradient(const Eigen::VectorXd& x, Eigen::VectorXd* dmean,
                                                  Eigen::VectorXd* dstd) const {
  const double amp = std::exp(hyper_.log_amplitude);
  const Eigen::ArrayXd inv_l2 = (-2.0 * hyper_.log_length_scales.array()).exp();
  const bool gradient = dmean || dstd;
  // Every point at once: differences (n x d), scaled distances, then the kernel policy over the n values.
  Eigen::ArrayXXd diff = (-X_).rowwise() + x.transpose();
  const Eigen::ArrayXd r = (diff.square().rowwise() * inv_l2.transpose()).rowwise().sum().sqrt();
  Eigen::VectorXd k(n_);
  Eigen::MatrixXd dk;  // dk_i/dx, when a gradient is asked for
  if (gradient) {
    Eigen::ArrayXd value, slope;
    Kernel::value_and_slope(r, value, slope);
    k = amp * value.matrix();
    diff.rowwise() *= inv_l2.transpose();
    diff.colwise() *= -amp * slope;
    dk = diff.matrix();
  } else {
    k = (amp * Kernel::value(r)).matrix();
  }
  Prediction p;
  const double mean_std = k.dot(alpha_);
  const Eigen::VectorXd Kinv_k = solve(k);
  const double var = std::max(amp - k.dot(Kinv_k), 1e-12 * amp);
  p.mean = y_mean_ + y_scale_ * mean_std;
  p.std = y_scale_ * std::sqrt(var);
  if (dmean) *dmean = y_scale_ * (dk.transpose() * alpha_);
  if (dstd) {
    const Eigen::VectorXd dvar = -2.0 * dk.transpose() * Kinv_k;
    *dstd = y_scale_ * dvar / (2.0 * std::sqrt(var));
  }
  return p;
}

void GaussianProcess::predict_many(const Eigen::MatrixXd& C, Eigen::VectorXd* mean, Eigen::VectorXd* std) const {
  predict_candidates(candidate_posterior(C), mean, std);
}

CandidatePosterior GaussianProcess::candidate_posterior(const Eigen::MatrixXd& C) const {
  CandidatePosterior cp;
  cp.C = C;
  cp.rows = n_;
  cp.V = kernel(X_, C.transpose(), hyper_);  // k(X, C), then L^-1 k(X, C) in place
  Eigen::MatrixXd& V = cp.V;
  cp.mean_std.noalias() = V.transpose() * alpha_;
  L_.triangularView<Eigen::Lower>().solveInPlace(V);
  cp.var_taken = V.colwise().squaredNorm().transpose();
  cp.z = L_.triangularView<Eigen::Lower>().solve(y_std_);
  return cp;
}

void GaussianProcess::extend(CandidatePosterior& cp) const {
  const int n = cp.rows, m = n_ - cp.rows;
  if (m <= 0) return;
  // New rows of L: [B^T Cs] (append_fixed). Rows of V and z: Cs^-1 (k(U, C) - B^T V), Cs^-1 (y_U - B^T z).
  const auto Bt = L_.block(n, 0, m, n);
  const auto Cs = L_.block(n, n, m, m).triangularView<Eigen::Lower>();
  cp.V.conservativeResize(n_, Eigen::NoChange);  // a copy of V (cheap beside the products below)
  auto Vnew = cp.V.middleRows(n, m);
  Vnew = kernel(X_.middleRows(n, m), cp.C.transpose(), hyper_);
  Vnew.noalias() -= Bt * cp.V.topRows(n);
  Cs.solveInPlace(Vnew);
  Eigen::VectorXd znew = y_std_.segment(n, m);
  znew.noalias() -= Bt * cp.z;
  Cs.solveInPlace(znew);
  cp.mean_std.noalias() += Vnew.transpose() * znew;
  cp.var_taken += Vnew.colwise().squaredNorm().transpose();
  cp.z.conservativeResize(n_);
  cp.z.tail(m) = znew;
  cp.rows = n_;
}

void GaussianProcess::predict_candidates(const CandidatePosterior& cp, Eigen::VectorXd* mean, Eigen::VectorXd* std) const {
  const double amp = std::exp(hyper_.log_amplitude);
  *mean = cp.mean_std.array() * y_scale_ + y_mean_;
  const Eigen::ArrayXd var = (amp - cp.var_taken.array()).max(1e-12 * amp);
  *std = y_scale_ * var.sqrt();
}

}  // namespace cpgmatch::bo
