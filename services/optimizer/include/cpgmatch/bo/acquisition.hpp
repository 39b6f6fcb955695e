// Acquisition functions, all written as quantities to *minimise* (scikit-optimize's convention):
//
//   LCB = mu - kappa sigma
//   EI  = -E[max(y_best - xi - f, 0)]      (negative expected improvement)
//   PI  = -P(f < y_best - xi)              (negative probability of improvement)
//
// Each returns its value and its derivatives with respect to mu and sigma, so the optimizer can chain
// them with the GP's gradients for L-BFGS refinement.
//
// Each acquisition is a policy type (as in limbo), written once: a static evaluate(mean, std, params)
// and a static safe(...) for the fall-weighted form. The enum Acquisition names them for options, files
// and gp_hedge's portfolio; with_acquisition() is the one place that maps a name to its type, so a new
// acquisition is a type and one line there.
#pragma once

#include <stdexcept>
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

struct AcquisitionParameters {
  double y_best = 0.0;  // the best (lowest) model-unit value so far
  double xi = 0.01;     // EI/PI margin
  double kappa = 1.96;  // LCB weight
};

// The fall-weighted acquisition (see evaluate_safe_acquisition below); d_p is d value / d p_safe.
struct SafeAcquisitionValue {
  double value = 0.0;
  double d_mean = 0.0;
  double d_std = 0.0;
  double d_p = 0.0;
};

// A fall never improves on the best: EI and PI of the mixture are p_safe times the plain ones.
template <typename Policy>
struct ScaledBySafety {
  static SafeAcquisitionValue safe(double mean, double std, double p, double /*fall_level*/,
                                   const AcquisitionParameters& q) {
    const AcquisitionValue v = Policy::evaluate(mean, std, q);
    return {p * v.value, p * v.d_mean, p * v.d_std, v.value};
  }
};

struct ExpectedImprovement : ScaledBySafety<ExpectedImprovement> {
  static AcquisitionValue evaluate(double mean, double std, const AcquisitionParameters& q);
};
struct ProbabilityOfImprovement : ScaledBySafety<ProbabilityOfImprovement> {
  static AcquisitionValue evaluate(double mean, double std, const AcquisitionParameters& q);
};
struct LowerConfidenceBound {
  static AcquisitionValue evaluate(double mean, double std, const AcquisitionParameters& q);
  // The bound if the proposal stands, the fall's cost if it falls. (The mixture's own lower bound would
  // reward the spread between the two outcomes: the riskier the point, the more it would look worth
  // exploring.)
  static SafeAcquisitionValue safe(double mean, double std, double p, double fall_level, const AcquisitionParameters& q);
};

// Calls f(Policy{}) with the policy type of a base acquisition (not kHedge: a portfolio, not a policy).
template <typename F>
decltype(auto) with_acquisition(Acquisition a, F&& f) {
  switch (a) {
    case Acquisition::kExpectedImprovement: return f(ExpectedImprovement{});
    case Acquisition::kProbabilityOfImprovement: return f(ProbabilityOfImprovement{});
    case Acquisition::kLowerConfidenceBound: return f(LowerConfidenceBound{});
    case Acquisition::kHedge: break;
  }
  throw std::logic_error("gp_hedge is a portfolio, not a single acquisition");
}

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
SafeAcquisitionValue evaluate_safe_acquisition(Acquisition a, double mean, double std, double p_safe,
                                               double fall_level, double y_best, double xi, double kappa);

}  // namespace cpgmatch::bo
