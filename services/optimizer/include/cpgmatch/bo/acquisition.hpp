// Acquisition functions, all written as quantities to *minimise* (scikit-optimize's convention):
//
//   LCB = mu - kappa sigma
//   EI  = -E[max(y_best - xi - f, 0)]      (negative expected improvement)
//   PI  = -P(f < y_best - xi)              (negative probability of improvement)
//
// Each returns its value and its derivatives with respect to mu and sigma, so the optimizer can chain
// them with the GP's gradients for L-BFGS refinement.
#pragma once

#include <string>
#include <string_view>

namespace cpgmatch::bo {

enum class Acquisition { kExpectedImprovement, kProbabilityOfImprovement, kLowerConfidenceBound, kHedge };

std::string to_string(Acquisition a);
// "ei", "pi", "lcb", "gp_hedge"; throws InputError otherwise.
Acquisition acquisition_from_string(std::string_view name);

struct AcquisitionValue {
  double value = 0.0;
  double d_mean = 0.0;
  double d_std = 0.0;
};

AcquisitionValue lower_confidence_bound(double mean, double std, double kappa);
AcquisitionValue negative_expected_improvement(double mean, double std, double y_best, double xi);
AcquisitionValue negative_probability_of_improvement(double mean, double std, double y_best, double xi);

// Dispatches on a base acquisition (not kHedge).
AcquisitionValue evaluate_acquisition(Acquisition a, double mean, double std, double y_best, double xi, double kappa);

}  // namespace cpgmatch::bo
