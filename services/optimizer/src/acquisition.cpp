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

AcquisitionValue lower_confidence_bound(double mean, double std, double kappa) {
  return {mean - kappa * std, 1.0, -kappa};
}

AcquisitionValue negative_expected_improvement(double mean, double std, double y_best, double xi) {
  const double improvement = y_best - xi - mean;
  if (std <= 0.0) return {-std::max(improvement, 0.0), improvement > 0.0 ? 1.0 : 0.0, 0.0};
  const double z = improvement / std;
  const double cdf = normal_cdf(z), pdf = normal_pdf(z);
  const double ei = improvement * cdf + std * pdf;
  // dEI/dmu = -cdf, dEI/dstd = pdf; negated for minimisation.
  return {-ei, cdf, -pdf};
}

AcquisitionValue negative_probability_of_improvement(double mean, double std, double y_best, double xi) {
  const double improvement = y_best - xi - mean;
  if (std <= 0.0) return {improvement > 0.0 ? -1.0 : 0.0, 0.0, 0.0};
  const double z = improvement / std;
  const double pdf = normal_pdf(z);
  // dPI/dmu = -pdf/std, dPI/dstd = -pdf z/std; negated.
  return {-normal_cdf(z), pdf / std, pdf * z / std};
}

AcquisitionValue evaluate_acquisition(Acquisition a, double mean, double std, double y_best, double xi, double kappa) {
  switch (a) {
    case Acquisition::kExpectedImprovement: return negative_expected_improvement(mean, std, y_best, xi);
    case Acquisition::kProbabilityOfImprovement: return negative_probability_of_improvement(mean, std, y_best, xi);
    case Acquisition::kLowerConfidenceBound: return lower_confidence_bound(mean, std, kappa);
    case Acquisition::kHedge: break;
  }
  throw std::logic_error("evaluate_acquisition: gp_hedge is a portfolio, not a single acquisition");
}

SafeAcquisitionValue evaluate_safe_acquisition(Acquisition a, double mean, double std, double p_safe,
                                               double fall_level, double y_best, double xi, double kappa) {
  const double p = std::clamp(p_safe, 0.0, 1.0);
  if (a != Acquisition::kLowerConfidenceBound) {
    const AcquisitionValue v = evaluate_acquisition(a, mean, std, y_best, xi, kappa);
    return {p * v.value, p * v.d_mean, p * v.d_std, v.value};
  }
  // The bound if the proposal stands, the fall's cost if it falls. (The mixture's own lower bound would
  // reward the spread between the two outcomes: the riskier the point, the more it would look worth
  // exploring.)
  const double bound = mean - kappa * std;
  SafeAcquisitionValue out;
  out.value = p * bound + (1.0 - p) * fall_level;
  out.d_mean = p;
  out.d_std = -kappa * p;
  out.d_p = bound - fall_level;
  return out;
}

}  // namespace cpgmatch::bo
