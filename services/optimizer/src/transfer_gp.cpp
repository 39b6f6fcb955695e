#include "cpgmatch/bo/transfer_gp.hpp"

#include <stdexcept>
#include <string>

namespace cpgmatch::bo {

Eigen::VectorXd TransferHyperparameters::pack() const {
  const Eigen::VectorXd s = simulation.pack(), r = residual.pack();
  Eigen::VectorXd theta(s.size() + r.size());
  theta << s, r;
  return theta;
}

TransferHyperparameters TransferHyperparameters::unpack(const Eigen::VectorXd& theta) {
  if (theta.size() < 6 || theta.size() % 2 != 0) {
    throw std::invalid_argument("transfer hyperparameters: expected 2 d + 4 numbers, got " + std::to_string(theta.size()));
  }
  const Eigen::Index block = theta.size() / 2;
  return {GpHyperparameters::unpack(theta.head(block)), GpHyperparameters::unpack(theta.tail(block))};
}

TransferGP::TransferGP(GpOptions options) : options_(options), simulation_(options), residual_(options) {}

void TransferGP::fit(const Eigen::MatrixXd& Xs, const Eigen::VectorXd& ys, const Eigen::MatrixXd& Xh,
                     const Eigen::VectorXd& yh, bool optimise, std::mt19937_64& rng, const TransferHyperparameters* start) {
  if (Xs.rows() != ys.size() || Xh.rows() != yh.size()) {
    throw std::invalid_argument("TransferGP::fit: points and values differ in number");
  }
  if (Xs.rows() < 2) throw std::invalid_argument("TransferGP::fit: needs at least 2 simulation points");
  if (!optimise && !start) throw std::invalid_argument("TransferGP::fit: fixed hyperparameters need a start");
  simulation_ = GaussianProcess(options_);
  simulation_.fit(Xs, ys, optimise, rng, start ? &start->simulation : nullptr);
  residual_ = GaussianProcess(options_);
  if (Xh.rows() == 0) return;
  Eigen::VectorXd residual(Xh.rows());
  for (Eigen::Index i = 0; i < Xh.rows(); ++i) residual[i] = yh[i] - simulation_.predict(Xh.row(i).transpose()).mean;
  residual_.fit(Xh, residual, optimise, rng, start ? &start->residual : nullptr);
}

Prediction TransferGP::predict_hardware(const Eigen::VectorXd& x) const {
  const Prediction s = simulation_.predict(x);
  if (!residual_.fitted()) return s;
  const Prediction r = residual_.predict(x);
  return {s.mean + r.mean, r.std};
}

void TransferGP::predict_hardware_many(const Eigen::MatrixXd& C, Eigen::VectorXd* mean, Eigen::VectorXd* std) const {
  simulation_.predict_many(C, mean, std);
  if (!residual_.fitted()) return;
  Eigen::VectorXd rm;
  residual_.predict_many(C, &rm, std);
  *mean += rm;
}

TransferHyperparameters TransferGP::hyperparameters() const {
  TransferHyperparameters h{simulation_.hyperparameters(), residual_.hyperparameters()};
  // Before any hardware observation the residual GP has none of its own: the starting values it would use.
  if (h.residual.log_length_scales.size() != h.simulation.log_length_scales.size()) {
    h.residual = GpHyperparameters{};
    h.residual.log_length_scales = Eigen::VectorXd::Zero(h.simulation.log_length_scales.size());
  }
  return h;
}

}  // namespace cpgmatch::bo
