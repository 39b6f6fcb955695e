// The simple way to carry a simulation over to the robot (`strategy: transfer`): a hardware GP whose
// prior mean is the simulation GP's posterior mean,
//
//   hardware(x) = mean_sim(x) + r(x),   r ~ GP fitted to y_hw - mean_sim(x_hw)
//
// Both are plain GaussianProcess fits (each with its own hyperparameters by marginal likelihood); the
// simulation's uncertainty is not carried over (the hardware posterior's std is r's). Unlike
// MultiFidelityGP nothing ties the two scales together: a robot whose costs are the simulation's times
// 0.8 leaves a residual that looks like the simulation itself, which r must learn point by point. With no
// hardware observation the hardware posterior is the simulation's.
#pragma once

#include <random>

#include <Eigen/Core>

#include "cpgmatch/bo/gaussian_process.hpp"

namespace cpgmatch::bo {

struct TransferHyperparameters {
  GpHyperparameters simulation;
  GpHyperparameters residual;  // the hardware GP of y_hw - mean_sim

  Eigen::VectorXd pack() const;  // [simulation.pack(), residual.pack()]: 2 d + 4 numbers
  // Throws std::invalid_argument unless theta.size() == 2 d + 4 for some d >= 1.
  static TransferHyperparameters unpack(const Eigen::VectorXd& theta);
};

class TransferGP {
 public:
  explicit TransferGP(GpOptions options = {});

  // As MultiFidelityGP::fit: ns >= 2, nh >= 0; `start` is required when !optimise.
  void fit(const Eigen::MatrixXd& Xs, const Eigen::VectorXd& ys, const Eigen::MatrixXd& Xh, const Eigen::VectorXd& yh,
           bool optimise, std::mt19937_64& rng, const TransferHyperparameters* start = nullptr);

  Prediction predict_hardware(const Eigen::VectorXd& x) const;
  Prediction predict_simulation(const Eigen::VectorXd& x) const { return simulation_.predict(x); }
  void predict_hardware_many(const Eigen::MatrixXd& C, Eigen::VectorXd* mean, Eigen::VectorXd* std) const;

  TransferHyperparameters hyperparameters() const;
  bool fitted() const { return simulation_.fitted(); }

 private:
  GpOptions options_;
  GaussianProcess simulation_;
  GaussianProcess residual_;
};

}  // namespace cpgmatch::bo
