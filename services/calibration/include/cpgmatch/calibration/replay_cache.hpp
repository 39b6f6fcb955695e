// The replays of every trace at one set of model values, remembered for the few sets a solver step asks
// about. Why: each tick is its own residual block (so that the robust loss acts per tick), and Ceres asks
// every block about the same values and the same numeric-difference neighbours; one replay must serve them
// all.
#pragma once

#include <cstddef>
#include <list>
#include <optional>
#include <vector>

#include "cpgmatch/calibration/calibration.hpp"

namespace cpgmatch::calibration {

class ReplayCache {
 public:
  // `scales[i]` turns the solver's i-th unknown into the value (unknown x value / scale ~ 1).
  ReplayCache(sim::PlanarLegModel start, std::vector<const ModelValue*> values, std::vector<double> scales,
              const std::vector<CalibrationTrace>& traces, std::size_t capacity);

  // The model with the solver's unknowns `x` set (each value clamped into its physical bounds).
  sim::PlanarLegModel model_at(const double* x) const;
  // The replay of every trace at `x`, in the traces' order; nullptr when one diverged.
  const std::vector<MeasuredTrace>* replays_at(const double* x);
  long replays_run() const { return replays_run_; }

 private:
  struct Entry {
    std::vector<double> x;
    std::optional<std::vector<MeasuredTrace>> replays;
  };
  sim::PlanarLegModel start_;
  std::vector<const ModelValue*> values_;
  std::vector<double> scales_;
  const std::vector<CalibrationTrace>& traces_;
  std::size_t capacity_;
  std::list<Entry> entries_;  // most recently used first
  long replays_run_ = 0;
};

}  // namespace cpgmatch::calibration
