#include "cpgmatch/bo/acquisition.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include <fmt/format.h>

#include "cpgmatch/errors.hpp"

namespace cpgmatch::bo {
namespace {

double normal_pdf(double z) { return std::exp(-0.5 * z * z) / std::sqrt(2.0 * std::numbers::pi); }
double normal_cdf(double z) { return 0.5 * std::erfc(-z / std::sqrt(2.0)); }

}  // namespace

std::string to_string(Acquisition a) {
  switch (a) {
    case Acquisition::kExpectedImprovement: return "ei";
    case Acquisition::kProbabilityOfImprovement: return "pi";
    case Acquisition::kLowerConfidenceBound: return "lcb";
    case Acquisition::kHedge: return "gp_hedge";
  }
  return "?";
}

Acquisition acquisition_from_string(std::string_view name) {
  if (name == "ei" || name == "EI") return Acquisition::kExpectedImprovement;
  if (name == "pi" || name == "PI") return Acquisition::kProbabilityOfImprovement;
  if (name == "lcb" || name == "LCB") return Acquisition::kLowerConfidenceBound;
  if (name == "gp_hedge" || name == "hedge") return Acquisition::kHedge;
  throw InputError(fmt::format("unknown acquisition '{}' (known: gp_hedge, ei, pi, lcb)", name));
}

AcquisitionValue LowerConfidenceBound::evaluate(double mean, double std, const AcquisitionParameters& q) {
  return {mean - q.kappa * std, 1.0, -q.kappa};
}

AcquisitionValue ExpectedImprovement::evaluate(double mean, double std, const AcquisitionParameters& q) {
  const double improvement = q.y_best - q.xi - mean;
  if (std <= 0.0) return {-std::max(improvement, 0.0), improvement > 0.0 ? 1.0 : 0.0, 0.0};
  const double z = improvement / std;
  const double cdf = normal_cdf(z), pdf = normal_pdf(z);
  const double ei = improvement * cdf + std * pdf;
  // dEI/dmu = -cdf, dEI/dstd = pdf; negated for minimisation.
  return {-ei, cdf, -pdf};
}

AcquisitionValue ProbabilityOfImprovement::evaluate(double mean, double std, const AcquisitionParameters& q) {
  const double improvement = q.y_best - q.xi - mean;
  if (std <= 0.0) return {improvement > 0.0 ? -1.0 : 0.0, 0.0, 0.0};
  const double z = improvement / std;
  const double pdf = normal_pdf(z);
  // dPI/dmu = -pdf/std, dPI/dstd = -pdf z/std; negated.
  return {-normal_cdf(z), pdf / std, pdf * z / std};
}

SafeAcquisitionValue LowerConfidenceBound::safe(double mean, double std, double p, double fall_level,
                                                const AcquisitionParameters& q) {
  const double bound = mean - q.kappa * std;
  SafeAcquisitionValue out;
  out.value = p * bound + (1.0 - p) * fall_level;
  out.d_mean = p;
  out.d_std = -q.kappa * p;
  out.d_p = bound - fall_level;
  return out;
}

AcquisitionValue lower_confidence_bound(double mean, double std, double kappa) {
  return LowerConfidenceBound::evaluate(mean, std, {0.0, 0.0, kappa});
}

AcquisitionValue negative_expected_improvement(double mean, double std, double y_best, double xi) {
  return ExpectedImprovement::evaluate(mean, std, {y_best, xi, 0.0});
}

AcquisitionValue negative_probability_of_improvement(double mean, double std, double y_best, double xi) {
  return ProbabilityOfImprovement::evaluate(mean, std, {y_best, xi, 0.0});
}

AcquisitionValue evaluate_acquisition(Acquisition a, double mean, double std, double y_best, double xi, double kappa) {
  const AcquisitionParameters q{y_best, xi, kappa};
  return with_acquisition(a, [&](auto policy) { return decltype(policy)::evaluate(mean, std, q); });
}

SafeAcquisitionValue evaluate_safe_acquisition(Acquisition a, double mean, double std, double p_safe,
                                               double fall_level, double y_best, double xi, double kappa) {
  const double p = std::clamp(p_safe, 0.0, 1.0);
  const AcquisitionParameters q{y_best, xi, kappa};
  return with_acquisition(a, [&](auto policy) { return decltype(policy)::safe(mean, std, p, fall_level, q); });
}

}  // namespace cpgmatch::bo
