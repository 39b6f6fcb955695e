// What a fitted value's standard deviation is, and whether the fit identified it at all. Two measures, the
// larger printed: the covariance (the residuals' noise, scaled by their own size) and the spread of the
// windows' separate answers (a model that explains each stretch of the trace with another value; the
// covariance cannot see that, and on an emulator's traces it was hundreds of times too small).
#pragma once

#include <vector>

#include "cpgmatch/calibration/calibration.hpp"

namespace cpgmatch::calibration {

struct Spread {
  double sd = 0.0;  // sample standard deviation; NaN for fewer than 2 numbers
  double se = 0.0;  // sd / sqrt(count), the standard error of their mean
};
Spread spread_of(const std::vector<double>& xs);

// Two values whose estimates are correlated beyond this cannot be told apart by these traces: any sd the
// pair is given describes a line in their plane, not each value.
inline constexpr double kIndistinguishableCorrelation = 0.995;

// An sd above this fraction of the estimate: its 2-sd interval runs from about half the value to one and a
// half times it, so the traces give the value's order, not the value (the gearbox's viscous friction on the
// matched trot: windows 40-50% apart, docs/calibration.md).
inline constexpr double kLooseRelativeSd = 0.25;

// Fills each value's covariance_sd, window_estimates, window_sd and window_se, standard_deviation (the larger
// of covariance_sd and window_sd) with sd_from, and identifiable with its reason. `covariance` is n x n in
// the values' units, row-major, all NaN when singular; `window_rows` one row of estimates per window.
void settle_uncertainty(std::vector<FittedValue>& values, const std::vector<double>& covariance,
                        const std::vector<std::vector<double>>& window_rows);

}  // namespace cpgmatch::calibration
