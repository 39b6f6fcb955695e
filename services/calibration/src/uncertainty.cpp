#include "cpgmatch/calibration/uncertainty.hpp"

#include <cmath>
#include <limits>

#include <fmt/format.h>

namespace cpgmatch::calibration {

Spread spread_of(const std::vector<double>& xs) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  if (xs.size() < 2) return {nan, nan};
  double mean = 0.0;
  for (double x : xs) mean += x;
  mean /= static_cast<double>(xs.size());
  double ss = 0.0;
  for (double x : xs) ss += (x - mean) * (x - mean);
  const double sd = std::sqrt(ss / static_cast<double>(xs.size() - 1));
  return {sd, sd / std::sqrt(static_cast<double>(xs.size()))};
}

void settle_uncertainty(std::vector<FittedValue>& values, const std::vector<double>& covariance,
                        const std::vector<std::vector<double>>& window_rows) {
  const std::size_t n = values.size();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (std::size_t i = 0; i < n; ++i) {
    FittedValue& v = values[i];
    const double variance = covariance[i * n + i];
    v.covariance_sd = variance >= 0.0 ? std::sqrt(variance) : nan;
    v.window_estimates.clear();
    for (const auto& row : window_rows) v.window_estimates.push_back(row.at(i));
    const Spread spread = spread_of(v.window_estimates);
    v.window_sd = spread.sd;
    v.window_se = spread.se;
    // The windows' scatter itself, not its standard error: the windows are not independent draws of one noise.
    // They share the model's errors and the objective's roughness, which averaging them does not remove, so
    // the joint answer may be off by as much as one window's (measured: docs/calibration.md). A missing
    // spread (one window) leaves the covariance alone, a lower bound then, and sd_from says so.
    const bool windows_larger = std::isfinite(v.window_sd) && !(v.window_sd <= v.covariance_sd);
    v.standard_deviation = windows_larger ? v.window_sd : v.covariance_sd;
    v.sd_from = windows_larger ? "windows" : "covariance";
    v.identifiable = true;
    v.not_identifiable_reason.clear();
    if (!std::isfinite(v.covariance_sd)) {
      v.identifiable = false;
      v.not_identifiable_reason = "the covariance is singular: the cost does not change with it (these traces do not "
                                  "excite it), or it trades exactly against another value";
    } else if (v.at_bound) {
      v.identifiable = false;
      v.not_identifiable_reason = fmt::format("at its physical bound [{}, {}]: the answer lies beyond the range, or the "
                                              "cost is flat towards it", v.lower, v.upper);
    } else {
      for (std::size_t j = 0; j < n; ++j) {
        if (j == i) continue;
        const double rho = covariance[i * n + j] / std::sqrt(covariance[i * n + i] * covariance[j * n + j]);
        if (std::abs(rho) > kIndistinguishableCorrelation) {
          v.identifiable = false;
          v.not_identifiable_reason = fmt::format("correlated {:.4f} with {}: these traces cannot tell the two apart", rho,
                                                  values[j].name);
          break;
        }
      }
    }
    if (v.identifiable && std::abs(v.standard_deviation) > kLooseRelativeSd * std::abs(v.estimate)) {
      // The sd is kept: it is honest, only too large for the value to count as fitted.
      v.identifiable = false;
      v.not_identifiable_reason = fmt::format("the sd ({:.3g}, from the {}) is over {:.0f}% of the estimate: these traces "
                                              "give its order, not its value", v.standard_deviation, v.sd_from,
                                              100.0 * kLooseRelativeSd);
      continue;
    }
    if (!v.identifiable) v.standard_deviation = nan;
  }
}

}  // namespace cpgmatch::calibration
