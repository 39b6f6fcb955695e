#include "cpgmatch/calibration/window_fits.hpp"

#include <algorithm>

namespace cpgmatch::calibration {

std::vector<CalibrationTrace> cut_windows(const std::vector<CalibrationTrace>& traces, std::size_t per_trace) {
  std::vector<CalibrationTrace> windows;
  for (const CalibrationTrace& trace : traces) {
    const std::size_t first = trace.first_fitted_tick;
    const std::size_t end = trace.measured.ticks.size();
    if (end <= first) continue;
    const std::size_t count = std::clamp<std::size_t>(per_trace, 1, end - first);
    const std::size_t length = (end - first) / count;
    for (std::size_t k = 0; k < count; ++k) {
      const std::size_t from = first + k * length;
      const std::size_t to = k + 1 == count ? end : from + length;
      CalibrationTrace window;
      window.measured.source = trace.measured.source;
      window.measured.ticks.assign(trace.measured.ticks.begin(), trace.measured.ticks.begin() + static_cast<long>(to));
      window.commands.assign(trace.commands.begin(), trace.commands.begin() + static_cast<long>(to));
      window.setup = trace.setup;
      window.first_fitted_tick = from;
      windows.push_back(std::move(window));
    }
  }
  return windows;
}

std::vector<std::vector<double>> window_estimates(const sim::PlanarLegModel& start, const std::vector<CalibrationTrace>& windows,
                                                  const CalibrationOptions& options) {
  CalibrationOptions alone = options;
  alone.grid_points = 0;  // the grid's best point (if any) is already the start
  alone.windows_per_trace = 1;
  alone.estimate_spread = false;
  std::vector<std::vector<double>> rows;
  for (const CalibrationTrace& window : windows) {
    Calibration fit(start, {window}, alone);
    const CalibrationResult r = fit.solve();
    std::vector<double> row;
    for (const FittedValue& v : r.values) row.push_back(v.estimate);
    rows.push_back(std::move(row));
  }
  return rows;
}

}  // namespace cpgmatch::calibration
