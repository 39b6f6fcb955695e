// Where do rollouts fall? A Gaussian-process classifier over the unit cube, used to weight the
// acquisitions by the probability that a proposal does not fall (constrained Bayesian optimisation:
// Gardner et al. 2014, Gelbart et al. 2014).
//
// Why a second model: the cost GP sees a fall only as a high cost, and in log units it smooths the
// fall cliff (a fall is ~3.5 above a good gait, the same step as between a good and a mediocre gait).
// Measured on the 5 seeds of a `cpgmatch reproduce` run (675 proposals after the initial design, 46 of
// them fell): a classifier fitted on the trials before each proposal ranked the falls with AUC 0.84 and
// gave them a mean fall probability of 0.28 against 0.03 for the rollouts that did not fall; the log-cost
// GP's own P(cost > fall level) ranked them as well (AUC 0.87) but put only 0.13 on the falls.
//
// The classifier is least-squares classification (Rasmussen & Williams 2006, sec. 6.5): GP regression on
// labels +1 (fell) / -1 (did not), hyperparameters by marginal likelihood like the cost GP, and
//   P(no fall | x) = Phi(-mean(x) / std(x))
// with the latent std. Far from every observation the prior mean is the standardised label mean, so
// the probability falls back to the observed fall rate's side of 0.5 rather than to a guess.
#pragma once

#include <random>
#include <vector>

#include <Eigen/Core>

#include "cpgmatch/bo/gaussian_process.hpp"

namespace cpgmatch::bo {

struct SafeProbability {
  double p = 1.0;          // P(no fall)
  Eigen::VectorXd dp_dx;   // filled only when asked for
};

class FallModel {
 public:
  explicit FallModel(GpOptions options = {});

  // X: n x d points in the unit cube; fell: n outcomes. Needs at least one fall and one non-fall,
  // otherwise the model stays empty (active() false: every probability is 1).
  void fit(const Eigen::MatrixXd& X, const std::vector<bool>& fell, bool optimise, std::mt19937_64& rng,
           const GpHyperparameters* start);

  bool active() const { return gp_.fitted(); }
  const GpHyperparameters& hyperparameters() const { return gp_.hyperparameters(); }

  double probability_safe(const Eigen::VectorXd& u) const;
  // With the gradient with respect to u.
  SafeProbability probability_safe_with_gradient(const Eigen::VectorXd& u) const;
  // For the columns of C.
  Eigen::VectorXd probability_safe_many(const Eigen::MatrixXd& C) const;

 private:
  GpOptions options_;
  GaussianProcess gp_;
};

}  // namespace cpgmatch::bo
