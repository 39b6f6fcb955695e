// Fits chosen model values so that the simulation, given the commands a robot received, does what the robot
// measured (nonlinear least squares with Ceres). The traces come from anywhere (measured_trace.hpp); the
// result says each value's estimate, its standard deviation and the misfit before and after.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "cpgmatch/calibration/model_values.hpp"
#include "cpgmatch/calibration/trace_replay.hpp"
#include "cpgmatch/calibration/trace_residuals.hpp"

namespace cpgmatch::calibration {

// One measured rollout, ready to replay: the trace, the commands it was made with, and how to replay it.
struct CalibrationTrace {
  MeasuredTrace measured;
  CommandSequence commands;
  ReplaySetup setup;
  // The first tick whose residuals count: a window later in the trace is replayed from the trace's start
  // (the plant cannot be set to a measured state mid-rollout), and only its own ticks are fitted.
  std::size_t first_fitted_tick = 0;
};

// Builds one from a measured trace and the CPG parameters and rollout settings it was made with (checks
// them against the trace's commands, see commands_of); `window_s` (> 0) keeps its first seconds.
CalibrationTrace prepare_trace(MeasuredTrace measured, const CpgParameters& params, const RolloutSettings& settings,
                               const sim::TerrainSpec& terrain, std::uint64_t seed, double window_s);

struct CalibrationOptions {
  std::vector<const ModelValue*> values;  // what to fit; everything else stays the start model's
  ResidualScales scales;
  // Robust loss on each tick's residuals (Huber): a tick whose residuals' RMS exceeds this many scales counts
  // linearly, not quadratically (a slip or a touchdown that came a poll early is not a reason to bend the model).
  double robust_rms = 3.0;
  // Central differences with this step relative to each value: larger than the contact events' roughness
  // (a touchdown moves by a whole poll when a value crosses a threshold), small against the value.
  double relative_step = 0.02;
  int max_iterations = 25;
  // Before the local solve, try this many evenly spaced points across each value's physical range, one
  // value after the other, and start from the best (0: start from the start model). Why: some values act
  // only past a threshold (a foot slides only when friction is below what the gait asks of it), so the
  // cost is flat on one side of the answer and a gradient method started there never moves.
  int grid_points = 0;
  // Each trace's ticks are cut into this many consecutive windows of equal length, and the fit is repeated
  // on each window alone (started from the joint answer) to see how far the windows disagree (the spread,
  // FittedValue::window_sd). 1: one window per trace, so the spread is over traces.
  std::size_t windows_per_trace = 3;
  // False skips the per-window fits (no spread; the per-window fits themselves run so).
  bool estimate_spread = true;
};

// The RMS of each channel's misfit over every tick, in the channel's own unit.
struct ChannelRms {
  double knee_rad = 0.0;
  double hip_rad = 0.0;
  double pitch_rad = 0.0;
  double speed_mps = 0.0;
  double contact_mismatch = 0.0;  // fraction of leg-ticks whose contact differs
  double foot_force_n = 0.0;
};

struct FittedValue {
  std::string name;
  std::string unit;
  double initial = 0.0;
  double estimate = 0.0;
  // One standard deviation: the larger of covariance_sd and window_sd (sd_from says which). The covariance
  // counts only the residuals' noise; the windows' disagreement counts a model that explains each stretch
  // of the trace with another value. NaN when not identifiable for a singular covariance, a bound or a
  // correlated pair (uncertainty.hpp); kept when the reason is only its size.
  double standard_deviation = 0.0;
  double lower = 0.0;
  double upper = 0.0;
  bool at_bound = false;
  double covariance_sd = 0.0;  // Ceres' covariance x sigma^2 = SSR / (residuals - values); NaN when singular
  std::vector<double> window_estimates;  // one per window (per trace when one window each)
  double window_sd = 0.0;  // their standard deviation (NaN for fewer than 2)
  double window_se = 0.0;  // window_sd / sqrt(count): the standard error of their mean (reported, not used: see uncertainty.cpp)
  std::string sd_from;     // "covariance" or "windows": which one standard_deviation is
  bool identifiable = true;
  // Why not: a singular covariance, a bound, a value it cannot tell from another, an sd over a quarter of it.
  std::string not_identifiable_reason;
};

struct CalibrationResult {
  std::vector<FittedValue> values;
  sim::PlanarLegModel model;       // the start model with the estimates
  double cost_before = 0.0;    // Ceres' cost, 1/2 sum of the robustified squared residuals
  double cost_after = 0.0;
  ChannelRms rms_before;
  ChannelRms rms_after;
  std::size_t residual_count = 0;
  int iterations = 0;
  long simulations = 0;        // replays run (each trace counts once), the grid's included, the windows' not
  std::size_t window_count = 0;  // windows fitted alone for the spread (0: none, fewer than 2)
  std::vector<double> solver_start;  // where the local solve started (the start model's values unless a grid moved them)
  double wall_time_s = 0.0;
  bool converged = false;
  std::string solver_report;   // Ceres' one-line summary
};

class Calibration {
 public:
  Calibration(sim::PlanarLegModel start, std::vector<CalibrationTrace> traces, CalibrationOptions options);
  ~Calibration();
  Calibration(const Calibration&) = delete;
  Calibration& operator=(const Calibration&) = delete;

  CalibrationResult solve();
  // The cost (as in CalibrationResult) with the fitted values set to `values` (the others the start
  // model's): to look at the objective's shape around an answer.
  double cost_at(const std::vector<double>& values);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace cpgmatch::calibration
