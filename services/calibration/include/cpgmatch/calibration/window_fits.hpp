// The windows a calibration's traces are cut into, and the fit repeated on each window alone: how far the
// windows' answers disagree is the part of the uncertainty that the residuals' noise does not show (a model
// that explains each stretch of the robot's motion with another value).
#pragma once

#include <vector>

#include "cpgmatch/calibration/calibration.hpp"

namespace cpgmatch::calibration {

// Each trace's fitted ticks cut into `per_trace` consecutive windows of equal length (the last takes the
// remainder; a trace with fewer ticks than windows gives one window per tick left). A window keeps the
// ticks before it, replayed but not fitted (first_fitted_tick), and none after it.
std::vector<CalibrationTrace> cut_windows(const std::vector<CalibrationTrace>& traces, std::size_t per_trace);

// The fitted values' estimates of each window fitted alone, with `options` but no grid and no spread of its
// own, each a local solve from `start`: where the joint solve started (the start model, or the grid's best
// point). Not from the joint answer: on a rough cost a solve started at a minimum stays there, and the
// windows would agree because they were told to. One row per window, one column per value.
std::vector<std::vector<double>> window_estimates(const sim::PlanarLegModel& start, const std::vector<CalibrationTrace>& windows,
                                                  const CalibrationOptions& options);

}  // namespace cpgmatch::calibration
