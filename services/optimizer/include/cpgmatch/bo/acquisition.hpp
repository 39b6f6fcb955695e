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

// The acquisition when a proposal may fall (see fall_model.hpp). The outcome is a mixture: with
// probability p_safe a cost from the GP (mean, std), otherwise a fall, whose cost in model units is
// fall_level (the mean of the observed falls). Then
//   EI  -> p_safe EI      (a fall never improves on the best: the mixture's expected improvement)
//   PI  -> p_safe PI      (the mixture's probability of improvement)
//   LCB -> p_safe (mean - kappa std) + (1 - p_safe) fall_level   (the bound if it stands, the fall if not)
// With p_safe = 1 each reduces exactly to the plain acquisition. d_p is d value / d p_safe.
struct SafeAcquisitionValue {
  double value = 0.0;
  double d_mean = 0.0;
  double d_std = 0.0;
  double d_p = 0.0;
};
SafeAcquisitionValue evaluate_safe_acquisition(Acquisition a, double mean, double std, double p_safe,
                                               double fall_level, double y_best, double xi, double kappa);

}  // namespace cpgmatch::bo
