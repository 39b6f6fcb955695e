#include "cpgmatch/calibration/calibration.hpp"

#include <chrono>
#include <cmath>
#include <limits>

#include <ceres/ceres.h>
#include <fmt/format.h>

#include "cpgmatch/calibration/replay_cache.hpp"
#include "cpgmatch/errors.hpp"
#include "cpgmatch/calibration/uncertainty.hpp"
#include "cpgmatch/calibration/window_fits.hpp"

namespace cpgmatch::calibration {
namespace {

// The residuals of one tick of one trace, from the shared replays.
class TickResiduals {
 public:
  TickResiduals(ReplayCache& cache, const MeasuredTrace& measured, std::size_t trace, std::size_t tick,
                const ResidualScales& scales)
      : cache_(cache), measured_(measured), trace_(trace), tick_(tick), scales_(scales) {}

  bool operator()(double const* const* parameters, double* residuals) const {
    const std::vector<MeasuredTrace>* replays = cache_.replays_at(parameters[0]);
    if (replays == nullptr) return false;  // a diverged simulation: Ceres rejects the step
    tick_residuals(measured_, (*replays)[trace_], tick_, tick_ + 1, scales_, residuals);
    return true;
  }

 private:
  ReplayCache& cache_;
  const MeasuredTrace& measured_;
  std::size_t trace_;
  std::size_t tick_;
  const ResidualScales& scales_;
};

// What a value is divided by for the solver: its start value, or a tenth of its range when it starts at 0
// (a relative step of 0 is no step).
double scale_of(const ModelValue& value, double start) {
  return start > 0.0 ? start : 0.1 * (value.upper - value.lower);
}

// The legs of the traces' robot (its first tick's); 4 for none, where nothing is fitted anyway.
std::size_t leg_count(const std::vector<CalibrationTrace>& traces) {
  for (const auto& t : traces) {
    if (!t.measured.ticks.empty()) return t.measured.ticks.front().legs.size();
  }
  return 4;
}

void accumulate(ChannelRms& sum, const MeasuredTick& m, const MeasuredTick& s) {
  for (std::size_t leg = 0; leg < m.legs.size(); ++leg) {
    sum.knee_rad += std::pow(s.legs[leg].knee_rad - m.legs[leg].knee_rad, 2);
    sum.hip_rad += std::pow(s.legs[leg].hip_rad - m.legs[leg].hip_rad, 2);
    sum.contact_mismatch += s.legs[leg].contact != m.legs[leg].contact ? 1.0 : 0.0;
    sum.foot_force_n += std::pow(s.legs[leg].foot_force_n - m.legs[leg].foot_force_n, 2);
  }
  sum.pitch_rad += std::pow(s.pitch_rad - m.pitch_rad, 2);
  sum.speed_mps += std::pow(s.vx_mps - m.vx_mps, 2);
}

}  // namespace

CalibrationTrace prepare_trace(MeasuredTrace measured, const CpgParameters& params, const RolloutSettings& settings,
                               const sim::TerrainSpec& terrain, std::uint64_t seed, double window_s) {
  if (!(window_s > 0.0)) throw InputError(fmt::format("window {} s: must be > 0", window_s));
  const auto ticks = static_cast<std::size_t>(std::lround(window_s * settings.controller.control_rate_hz));
  if (measured.ticks.size() > ticks) measured.ticks.resize(ticks);
  CalibrationTrace trace;
  trace.commands = commands_of(measured, params, settings);
  trace.measured = std::move(measured);
  trace.setup = {terrain, settings, seed};
  return trace;
}

struct Calibration::Impl {
  sim::PlanarLegModel start;
  std::vector<CalibrationTrace> traces;
  CalibrationOptions options;
  std::vector<double> scales;
  std::vector<double> x;  // the solver's unknowns: value / scale
  std::unique_ptr<ReplayCache> cache;
  ceres::HuberLoss loss;
  ceres::Problem problem;

  static ceres::Problem::Options problem_options() {
    ceres::Problem::Options o;
    o.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;  // one loss shared by every tick
    return o;
  }

  Impl(sim::PlanarLegModel start_model, std::vector<CalibrationTrace> t, CalibrationOptions o)
      : start(start_model),
        traces(std::move(t)),
        options(std::move(o)),
        loss(options.robust_rms * std::sqrt(static_cast<double>(residuals_per_tick(leg_count(traces))))),
        problem(problem_options()) {
    if (options.values.empty()) throw InputError("calibration: no model value to fit");
    if (traces.empty()) throw InputError("calibration: no trace");
    for (const ModelValue* v : options.values) {
      const double value = v->get(start);
      if (value < v->lower || value > v->upper) {
        throw InputError(fmt::format("{} = {} in the start model is outside its physical range [{}, {}] ({})", v->name,
                                     value, v->lower, v->upper, v->bounds_reason));
      }
      scales.push_back(scale_of(*v, value));
      x.push_back(value / scales.back());
    }
    const std::size_t n = x.size();
    // The point, its 2n central-difference neighbours, and a trial step.
    cache = std::make_unique<ReplayCache>(start, options.values, scales, traces, 2 * n + 2);
    ceres::NumericDiffOptions diff;
    diff.relative_step_size = options.relative_step;
    for (std::size_t k = 0; k < traces.size(); ++k) {
      for (std::size_t tick = traces[k].first_fitted_tick; tick < traces[k].measured.ticks.size(); ++tick) {
        auto* cost = new ceres::DynamicNumericDiffCostFunction<TickResiduals, ceres::CENTRAL>(
            new TickResiduals(*cache, traces[k].measured, k, tick, options.scales), ceres::TAKE_OWNERSHIP, diff);
        cost->AddParameterBlock(static_cast<int>(n));
        cost->SetNumResiduals(residuals_per_tick(traces[k].measured.ticks[tick].legs.size()));
        problem.AddResidualBlock(cost, &loss, x.data());
      }
    }
    for (std::size_t i = 0; i < n; ++i) {
      problem.SetParameterLowerBound(x.data(), static_cast<int>(i), options.values[i]->lower / scales[i]);
      problem.SetParameterUpperBound(x.data(), static_cast<int>(i), options.values[i]->upper / scales[i]);
    }
  }

  // Coordinate-wise over a grid in each value's bounds: moves x to the best point found.
  void grid_search() {
    const int k = options.grid_points;
    if (k < 2) return;
    double best = cost();
    for (std::size_t i = 0; i < x.size(); ++i) {
      const ModelValue& v = *options.values[i];
      double best_xi = x[i];
      for (int j = 0; j < k; ++j) {
        x[i] = (v.lower + (v.upper - v.lower) * j / (k - 1)) / scales[i];
        const double c = cost();
        if (c < best) best = c, best_xi = x[i];
      }
      x[i] = best_xi;
    }
  }

  double cost() {
    double c = 0.0;
    if (!problem.Evaluate(ceres::Problem::EvaluateOptions(), &c, nullptr, nullptr, nullptr)) {
      return std::numeric_limits<double>::infinity();
    }
    return c;
  }

  ChannelRms rms() {
    ChannelRms sum;
    const std::vector<MeasuredTrace>* replays = cache->replays_at(x.data());
    if (replays == nullptr) {
      const double inf = std::numeric_limits<double>::infinity();
      return {inf, inf, inf, inf, inf, inf};
    }
    std::size_t ticks = 0, leg_ticks = 0;
    for (std::size_t k = 0; k < traces.size(); ++k) {
      for (std::size_t i = traces[k].first_fitted_tick; i < traces[k].measured.ticks.size(); ++i) {
        accumulate(sum, traces[k].measured.ticks[i], (*replays)[k].ticks[i]);
        ++ticks;
        leg_ticks += traces[k].measured.ticks[i].legs.size();
      }
    }
    const double legs = static_cast<double>(leg_ticks);
    return {std::sqrt(sum.knee_rad / legs), std::sqrt(sum.hip_rad / legs), std::sqrt(sum.pitch_rad / ticks),
            std::sqrt(sum.speed_mps / ticks), sum.contact_mismatch / legs, std::sqrt(sum.foot_force_n / legs)};
  }

  // The covariance of the values (their units, n x n row-major), or all NaN where the Jacobian is rank
  // deficient.
  std::vector<double> covariance_matrix(double final_cost, std::size_t residuals) {
    const std::size_t n = x.size();
    std::vector<double> out(n * n, std::numeric_limits<double>::quiet_NaN());
    ceres::Covariance::Options co;
    co.algorithm_type = ceres::DENSE_SVD;  // says "rank deficient" instead of failing on a singular J'J
    ceres::Covariance covariance(co);
    const std::vector<std::pair<const double*, const double*>> blocks = {{x.data(), x.data()}};
    if (!covariance.Compute(blocks, &problem)) return out;
    std::vector<double> c(n * n);
    if (!covariance.GetCovarianceBlock(x.data(), x.data(), c.data())) return out;
    // Ceres assumes the residuals' scales are their true standard deviations; they are guesses, so the
    // covariance is scaled by the fit's own residual variance, sigma^2 = SSR / (residuals - values) with
    // SSR = 2 cost (the robustified sum), as for any least-squares fit with unknown noise.
    const double dof = static_cast<double>(residuals) - static_cast<double>(n);
    const double variance = dof > 0.0 ? 2.0 * final_cost / dof : std::numeric_limits<double>::quiet_NaN();
    for (std::size_t i = 0; i < n; ++i) {
      for (std::size_t j = 0; j < n; ++j) out[i * n + j] = c[i * n + j] * variance * scales[i] * scales[j];
    }
    return out;
  }
};

Calibration::Calibration(sim::PlanarLegModel start, std::vector<CalibrationTrace> traces, CalibrationOptions options)
    : impl_(std::make_unique<Impl>(start, std::move(traces), std::move(options))) {}

Calibration::~Calibration() = default;

double Calibration::cost_at(const std::vector<double>& values) {
  if (values.size() != impl_->x.size()) throw std::logic_error("cost_at: one value per fitted value");
  const std::vector<double> kept = impl_->x;
  for (std::size_t i = 0; i < values.size(); ++i) impl_->x[i] = values[i] / impl_->scales[i];
  const double c = impl_->cost();
  impl_->x = kept;
  return c;
}

CalibrationResult Calibration::solve() {
  const auto wall_start = std::chrono::steady_clock::now();
  Impl& m = *impl_;
  CalibrationResult result;
  result.cost_before = m.cost();
  result.rms_before = m.rms();
  m.grid_search();
  for (std::size_t i = 0; i < m.x.size(); ++i) result.solver_start.push_back(m.x[i] * m.scales[i]);
  const std::vector<double> solver_start_x = m.x;
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_QR;
  so.max_num_iterations = m.options.max_iterations;
  so.num_threads = 1;  // the replays share one cache and ODE worlds are per thread
  // The simulation with contact is not smooth below about a thousandth of a value: asking for more only
  // makes the solver chase the roughness.
  so.function_tolerance = 1e-5;
  so.parameter_tolerance = 1e-4;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &m.problem, &summary);
  result.cost_after = m.cost();
  result.rms_after = m.rms();
  result.residual_count = static_cast<std::size_t>(summary.num_residuals);
  result.iterations = static_cast<int>(summary.iterations.size()) - 1;
  result.converged = summary.termination_type == ceres::CONVERGENCE;
  result.solver_report = summary.BriefReport();
  const std::vector<double> covariance = m.covariance_matrix(result.cost_after, result.residual_count);
  result.model = m.cache->model_at(m.x.data());
  for (std::size_t i = 0; i < m.x.size(); ++i) {
    const ModelValue& v = *m.options.values[i];
    FittedValue f;
    f.name = v.name;
    f.unit = v.unit;
    f.initial = v.get(m.start);
    f.estimate = v.get(result.model);
    f.lower = v.lower;
    f.upper = v.upper;
    const double tolerance = 1e-6 * (v.upper - v.lower);
    f.at_bound = f.estimate <= v.lower + tolerance || f.estimate >= v.upper - tolerance;
    result.values.push_back(f);
  }
  result.simulations = m.cache->replays_run();
  std::vector<std::vector<double>> window_rows;
  if (m.options.estimate_spread) {
    const std::vector<CalibrationTrace> windows = cut_windows(m.traces, m.options.windows_per_trace);
    if (windows.size() >= 2) window_rows = window_estimates(m.cache->model_at(solver_start_x.data()), windows, m.options);
    result.window_count = windows.size() >= 2 ? windows.size() : 0;
  }
  settle_uncertainty(result.values, covariance, window_rows);
  result.wall_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  return result;
}

}  // namespace cpgmatch::calibration
