#include "cpgmatch/bo/hardware_optimizer.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <type_traits>

#include <fmt/format.h>

#include "cpgmatch/bo/acquisition.hpp"
#include "cpgmatch/errors.hpp"

namespace cpgmatch::bo {
namespace {

enum Purpose : std::uint64_t { kFitPurpose = 11, kSimFallPurpose = 12, kHardwareFallPurpose = 13, kAskPurpose = 14 };

// Calls f with the fitted model (MultiFidelityGP or TransferGP); throws when there is none yet.
template <typename Model, typename F>
void with_model(Model& model, F&& f) {
  std::visit(
      [&](auto& m) {
        if constexpr (std::is_same_v<std::decay_t<decltype(m)>, std::monostate>) {
          throw std::logic_error("HardwareOptimizer: no model yet (needs two successful simulation results)");
        } else {
          f(m);
        }
      },
      model);
}

}  // namespace

std::string to_string(HardwareStrategy s) { return s == HardwareStrategy::kTransfer ? "transfer" : "multi_fidelity"; }

std::string to_string(ProposalBasis b) {
  switch (b) {
    case ProposalBasis::kSimulationOptimum: return "simulation_optimum";
    case ProposalBasis::kEnqueuedGait: return "enqueued_gait";
    case ProposalBasis::kSafe: return "safe";
    case ProposalBasis::kLowestBound: return "lowest_bound";
    case ProposalBasis::kLeastLikelyToFall: return "least_likely_to_fall";
  }
  return "safe";
}

HardwareStrategy hardware_strategy_from_string(std::string_view name) {
  if (name == "transfer") return HardwareStrategy::kTransfer;
  if (name == "multi_fidelity") return HardwareStrategy::kMultiFidelity;
  throw InputError(fmt::format("unknown hardware strategy '{}' (known: transfer, multi_fidelity)", name));
}

void HardwareOptimizerOptions::validate() const {
  if (!(xi >= 0.0) || !std::isfinite(xi)) throw InputError("xi must be a finite number >= 0");
  if (!(max_fall_probability >= 0.0 && max_fall_probability <= 1.0)) {
    throw InputError(fmt::format("max_fall_probability must be within [0, 1], got {}", max_fall_probability));
  }
  if (candidates < 1) throw InputError("candidates must be >= 1");
  if (local_candidates < 0) throw InputError("local_candidates must be >= 0");
  if (local_centres < 1) throw InputError("local_centres must be >= 1");
  if (!(local_radius > 0.0) || !std::isfinite(local_radius)) throw InputError("local_radius must be > 0");
  if (!(model.min_rho < model.max_rho)) throw InputError("model.min_rho must be below model.max_rho");
  if (hyperparameter_restart_every < 1) throw InputError("hyperparameter_restart_every must be >= 1");
  if (hyperparameter_warm_evaluations < 1) throw InputError("hyperparameter_warm_evaluations must be >= 1");
  if (!(safe_margin >= 0.0) || !std::isfinite(safe_margin)) {
    throw InputError(fmt::format("safe_margin must be a finite number >= 0, got {}", safe_margin));
  }
  if (!(safe_beta >= 0.0) || !std::isfinite(safe_beta)) {
    throw InputError(fmt::format("safe_beta must be a finite number >= 0, got {}", safe_beta));
  }
}

CandidateChoice choose_hardware_candidate(const Eigen::VectorXd& ei, const Eigen::VectorXd& p_fall,
                                          double max_fall_probability) {
  return choose_hardware_candidate(ei, p_fall, max_fall_probability, Eigen::VectorXd::Zero(ei.size()),
                                   std::numeric_limits<double>::infinity());
}

CandidateChoice choose_hardware_candidate(const Eigen::VectorXd& ei, const Eigen::VectorXd& p_fall,
                                          double max_fall_probability, const Eigen::VectorXd& upper_bound,
                                          double cost_limit) {
  if (ei.size() != p_fall.size() || ei.size() != upper_bound.size() || ei.size() == 0) {
    throw std::invalid_argument(
        "choose_hardware_candidate: needs as many fall probabilities and bounds as candidates, >= 1");
  }
  CandidateChoice safe{-1, true, true}, lowest_bound{-1, true, false}, safest{-1, false, false};
  double best_score = -std::numeric_limits<double>::infinity();
  for (Eigen::Index j = 0; j < ei.size(); ++j) {
    const int i = static_cast<int>(j);
    if (p_fall[j] <= max_fall_probability) {
      if (upper_bound[j] <= cost_limit) {
        const double score = ei[j] * (1.0 - p_fall[j]);
        if (safe.index < 0 || score > best_score) {
          safe.index = i;
          best_score = score;
        }
      } else if (lowest_bound.index < 0 || upper_bound[j] < upper_bound[lowest_bound.index] ||
                 (upper_bound[j] == upper_bound[lowest_bound.index] && ei[j] > ei[lowest_bound.index])) {
        lowest_bound.index = i;
      }
    } else if (safest.index < 0 || p_fall[j] < p_fall[safest.index] ||
               (p_fall[j] == p_fall[safest.index] && ei[j] > ei[safest.index])) {
      safest.index = i;
    }
  }
  if (safe.index >= 0) return safe;
  if (lowest_bound.index >= 0) return lowest_bound;
  // Above the fall limit, the cost bound is not what decides; whether this one clears it is the caller's to say.
  safest.within_cost_bound = upper_bound[safest.index] <= cost_limit;
  return safest;
}

HardwareOptimizer::HardwareOptimizer(SearchSpace space, HardwareOptimizerOptions options)
    : space_(std::move(space)),
      options_(options),
      simulation_fall_(options.model.simulation),
      hardware_fall_(options.model.simulation) {
  options_.validate();
}

double HardwareOptimizer::to_model(double cost) const {
  return options_.cost_transform == CostTransform::kLog ? std::log(cost) : cost;
}

double HardwareOptimizer::from_model(double value) const {
  return options_.cost_transform == CostTransform::kLog ? std::exp(value) : value;
}

void HardwareOptimizer::check(const Observation& o, const char* where) const {
  space_.check_point(o.x);
  if (o.excluded && !o.failed) throw InputError(fmt::format("{}: an excluded observation must be a failed one", where));
  if (o.failed) return;
  if (!std::isfinite(o.y)) throw InputError(fmt::format("{}: cost must be a finite number, got {}", where, o.y));
  if (options_.cost_transform == CostTransform::kLog && !(o.y > 0.0)) {
    throw InputError(fmt::format("{}: cost must be > 0 with cost_transform log, got {}", where, o.y));
  }
}

void HardwareOptimizer::tell_simulation(const Observation& o, bool enqueued) {
  check(o, "tell_simulation");
  simulation_.push_back(o);
  simulation_enqueued_.push_back(enqueued);
}

std::optional<HardwareOptimizer::StartPoint> HardwareOptimizer::start_point() const {
  // The lowest cost, the earlier on ties (strict <): deterministic in the order the results were told.
  auto best_of = [&](bool enqueued_only) -> std::optional<std::size_t> {
    std::optional<std::size_t> best;
    for (std::size_t i = 0; i < simulation_.size(); ++i) {
      const Observation& o = simulation_[i];
      if (o.failed || o.fell || (enqueued_only && !simulation_enqueued_[i])) continue;
      if (!best || o.y < simulation_[*best].y) best = i;
    }
    return best;
  };
  if (const auto i = best_of(true)) return StartPoint{*i, ProposalBasis::kEnqueuedGait};
  if (const auto i = best_of(false)) return StartPoint{*i, ProposalBasis::kSimulationOptimum};
  return std::nullopt;
}

void HardwareOptimizer::tell_hardware(const Observation& o) {
  check(o, "tell_hardware");
  hardware_.push_back(o);
}

HardwareOptimizer::Dataset HardwareOptimizer::dataset(const std::vector<Observation>& observations,
                                                      std::size_t count) const {
  double worst = -std::numeric_limits<double>::infinity();
  int modelled = 0, successful = 0;
  for (std::size_t i = 0; i < count; ++i) {
    const Observation& o = observations[i];
    if (!o.failed) {
      worst = std::max(worst, o.y);
      ++successful;
    }
    if (!o.excluded) ++modelled;
  }
  Dataset d;
  const int dim = space_.size();
  // A failure with nothing successful beside it has no cost to stand for: left out.
  if (successful == 0) modelled = 0;
  d.X.resize(modelled, dim);
  d.y.resize(modelled);
  d.fall_X.resize(successful, dim);
  int row = 0, fall_row = 0;
  for (std::size_t i = 0; i < count && row < modelled; ++i) {
    const Observation& o = observations[i];
    if (o.excluded) continue;
    const Eigen::VectorXd u = space_.to_unit(o.x);
    d.X.row(row) = u.transpose();
    d.y[row++] = to_model(o.failed ? worst : o.y);
    if (!o.failed) {
      d.fall_X.row(fall_row++) = u.transpose();
      d.fell.push_back(o.fell);
    }
  }
  return d;
}

std::mt19937_64 HardwareOptimizer::rng_for(std::uint64_t purpose, std::uint64_t extra) const {
  std::seed_seq seq{static_cast<std::uint32_t>(options_.seed), static_cast<std::uint32_t>(options_.seed >> 32),
                    static_cast<std::uint32_t>(simulation_.size()), static_cast<std::uint32_t>(hardware_.size()),
                    static_cast<std::uint32_t>(purpose), static_cast<std::uint32_t>(extra)};
  return std::mt19937_64(seq);
}

bool HardwareOptimizer::stale() const {
  return std::holds_alternative<std::monostate>(model_) || fitted_simulation_ != static_cast<int>(simulation_.size()) ||
         fitted_hardware_ != static_cast<int>(hardware_.size());
}

void HardwareOptimizer::update() {
  if (!stale()) return;
  const int successful = static_cast<int>(
      std::count_if(simulation_.begin(), simulation_.end(), [](const Observation& o) { return !o.failed; }));
  if (successful < 2) return;
  fitted_simulation_ = static_cast<int>(simulation_.size());
  fitted_hardware_ = static_cast<int>(hardware_.size());
  fit_models(/*optimise=*/true);
}

void HardwareOptimizer::fit_models(bool optimise) {
  const Dataset sim = dataset(simulation_, static_cast<std::size_t>(fitted_simulation_));
  const Dataset hw = dataset(hardware_, static_cast<std::size_t>(fitted_hardware_));
  // Warm-started from the last fit every time, with random restarts every k-th fit (BayesianOptimizer's
  // schedule): a fit per hardware ask, not per simulated result.
  MultiFidelityOptions model_options = options_.model;
  const bool warm = optimise && have_hyper_ && fits_ % options_.hyperparameter_restart_every != 0;
  if (warm) {
    for (GpOptions* o : {&model_options.simulation, &model_options.discrepancy}) {
      o->random_restarts = 0;
      o->max_evaluations = options_.hyperparameter_warm_evaluations;
    }
  }
  auto rng = rng_for(kFitPurpose);
  auto fit = [&](auto& model) {
    using Hyper = std::decay_t<decltype(model.hyperparameters())>;
    std::optional<Hyper> start;
    if (have_hyper_) start = Hyper::unpack(hyper_);
    model.fit(sim.X, sim.y, hw.X, hw.y, optimise, rng, start ? &*start : nullptr);
    hyper_ = model.hyperparameters().pack();
  };
  if (options_.strategy == HardwareStrategy::kMultiFidelity) {
    MultiFidelityGP m(model_options);
    fit(m);
    model_ = std::move(m);
  } else {
    TransferGP t(model_options.simulation);
    fit(t);
    model_ = std::move(t);
  }
  have_hyper_ = true;

  if (options_.fall_model) {
    // One classifier per source (a simulated fall and a robot's fall are different evidence).
    auto fit_fall = [&](FallModel& fall, const Dataset& data, bool& have, Eigen::VectorXd& hyper, Purpose purpose) {
      fall = FallModel(model_options.simulation);
      auto fall_rng = rng_for(purpose);
      const GpHyperparameters start = have ? GpHyperparameters::unpack(hyper) : GpHyperparameters{};
      fall.fit(data.fall_X, data.fell, optimise, fall_rng, have ? &start : nullptr);
      if (optimise && fall.active()) {
        hyper = fall.hyperparameters().pack();
        have = true;
      }
    };
    fit_fall(simulation_fall_, sim, have_simulation_fall_, simulation_fall_hyper_, kSimFallPurpose);
    fit_fall(hardware_fall_, hw, have_hardware_fall_, hardware_fall_hyper_, kHardwareFallPurpose);
  }
  if (optimise) ++fits_;
}

Prediction HardwareOptimizer::predict_hardware(const Eigen::VectorXd& x) const {
  Prediction p;
  with_model(model_, [&](const auto& m) { p = m.predict_hardware(space_.to_unit(x)); });
  return p;
}

double HardwareOptimizer::fall_probability(const Eigen::VectorXd& x) const {
  const Eigen::VectorXd u = space_.to_unit(x);
  return std::max(1.0 - simulation_fall_.probability_safe(u), 1.0 - hardware_fall_.probability_safe(u));
}

HardwareProposal HardwareOptimizer::ask(const std::vector<Eigen::VectorXd>& pending) {
  for (const auto& p : pending) space_.check_point(p);
  update();
  const Dataset sim = dataset(simulation_, simulation_.size());
  Dataset hw = dataset(hardware_, hardware_.size());
  const int d = space_.size();

  // Pending hardware points: the kriging believer (the fitted model's mean there), hyperparameters held.
  auto working = model_;
  if (!pending.empty()) {
    const Eigen::Index n = hw.X.rows(), m = static_cast<Eigen::Index>(pending.size());
    hw.X.conservativeResize(n + m, d);
    hw.y.conservativeResize(n + m);
    for (Eigen::Index i = 0; i < m; ++i) {
      hw.X.row(n + i) = space_.to_unit(pending[static_cast<std::size_t>(i)]).transpose();
      hw.y[n + i] = predict_hardware(pending[static_cast<std::size_t>(i)]).mean;
    }
    with_model(working, [&](auto& model) {
      using Hyper = std::decay_t<decltype(model.hyperparameters())>;
      const Hyper h = Hyper::unpack(hyper_);
      std::mt19937_64 unused(0);
      model.fit(sim.X, sim.y, hw.X, hw.y, /*optimise=*/false, unused, &h);
    });
  }
  auto hardware_posterior = [&](const Eigen::MatrixXd& C, Eigen::VectorXd* mean, Eigen::VectorXd* std) {
    with_model(working, [&](const auto& model) { model.predict_hardware_many(C, mean, std); });
  };

  // The best hardware cost so far; before the first, the best the model expects at a simulated point.
  Eigen::MatrixXd observed(d, sim.X.rows() + hw.X.rows());
  observed << sim.X.transpose(), hw.X.transpose();
  Eigen::VectorXd observed_mean, observed_std;
  hardware_posterior(observed, &observed_mean, &observed_std);
  const int n_hw_observed = static_cast<int>(hw.X.rows() - static_cast<Eigen::Index>(pending.size()));
  const double y_best = n_hw_observed > 0 ? hw.y.head(n_hw_observed).minCoeff() : observed_mean.minCoeff();

  const std::optional<StartPoint> start = start_point();
  if (hardware_.empty() && pending.empty() && start) {
    // The first robot rollout: the transferred point itself, not a candidate near it. Its numbers are
    // reported as for any proposal; there is no robot cost yet to bound it against.
    const Eigen::VectorXd& x = simulation_[start->observation].x;
    HardwareProposal out;
    out.x = x;
    out.basis = start->basis;
    out.hardware = predict_hardware(x);
    out.expected_improvement =
        -negative_expected_improvement(out.hardware.mean, out.hardware.std, y_best, options_.xi).value;
    out.fall_probability = fall_probability(x);
    out.within_fall_limit = out.fall_probability <= options_.max_fall_probability;
    out.cost_bound = from_model(out.hardware.mean + options_.safe_beta * out.hardware.std);
    out.cost_limit = std::numeric_limits<double>::quiet_NaN();
    out.within_cost_bound = true;
    return out;
  }
  // The safe-exploration reference: the best robot cost that walked (successful, not fallen: a fall's cost
  // says nothing about how good a gait may be). Before there is one (the start point still pending, or
  // every robot rollout failed or fell), what the model expects of the start point. In model units.
  double reference = std::numeric_limits<double>::infinity();
  for (const Observation& o : hardware_) {
    if (!o.failed && !o.fell) reference = std::min(reference, to_model(o.y));
  }
  if (!std::isfinite(reference) && start) {
    with_model(working, [&](const auto& model) {
      reference = model.predict_hardware(space_.to_unit(simulation_[start->observation].x)).mean;
    });
  }
  // (1 + margin) times the reference cost, in model units: log adds log(1 + margin); in cost units the
  // margin is taken of |reference| so that it loosens the limit for a negative cost too.
  double limit_model = std::numeric_limits<double>::infinity();
  double cost_limit = std::numeric_limits<double>::quiet_NaN();
  if (std::isfinite(reference)) {
    limit_model = options_.cost_transform == CostTransform::kLog ? reference + std::log1p(options_.safe_margin)
                                                                 : reference + options_.safe_margin * std::abs(reference);
    cost_limit = from_model(limit_model);
  }

  auto rng = rng_for(kAskPurpose, pending.size());
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::normal_distribution<double> step(0.0, options_.local_radius);
  const int centres = std::min<int>(options_.local_centres, static_cast<int>(observed.cols()));
  std::vector<int> order(static_cast<std::size_t>(observed.cols()));
  std::iota(order.begin(), order.end(), 0);
  std::partial_sort(order.begin(), order.begin() + centres, order.end(),
                    [&](int a, int b) { return observed_mean[a] < observed_mean[b]; });
  const int per_centre = options_.local_candidates / centres;
  Eigen::MatrixXd C(d, options_.candidates + per_centre * centres);
  for (int j = 0; j < options_.candidates; ++j)
    for (int i = 0; i < d; ++i) C(i, j) = unit(rng);
  for (int c = 0, j = options_.candidates; c < centres; ++c) {
    for (int k = 0; k < per_centre; ++k, ++j)
      for (int i = 0; i < d; ++i) C(i, j) = std::clamp(observed(i, order[c]) + step(rng), 0.0, 1.0);
  }

  Eigen::VectorXd mean, std;
  hardware_posterior(C, &mean, &std);
  Eigen::VectorXd ei(C.cols()), p_fall(C.cols()), upper(C.cols());
  const Eigen::VectorXd safe_sim = simulation_fall_.probability_safe_many(C);
  const Eigen::VectorXd safe_hw = hardware_fall_.probability_safe_many(C);
  for (Eigen::Index j = 0; j < C.cols(); ++j) {
    ei[j] = -negative_expected_improvement(mean[j], std[j], y_best, options_.xi).value;
    p_fall[j] = std::max(1.0 - safe_sim[j], 1.0 - safe_hw[j]);
    upper[j] = mean[j] + options_.safe_beta * std[j];
  }
  const CandidateChoice choice =
      choose_hardware_candidate(ei, p_fall, options_.max_fall_probability, upper, limit_model);
  HardwareProposal out;
  out.x = space_.from_unit(C.col(choice.index));
  out.expected_improvement = ei[choice.index];
  out.fall_probability = p_fall[choice.index];
  out.within_fall_limit = choice.within_fall_limit;
  out.hardware = {mean[choice.index], std[choice.index]};
  out.cost_bound = from_model(upper[choice.index]);
  out.cost_limit = cost_limit;
  out.within_cost_bound = choice.within_cost_bound;
  out.basis = !choice.within_fall_limit ? ProposalBasis::kLeastLikelyToFall
              : choice.within_cost_bound ? ProposalBasis::kSafe
                                         : ProposalBasis::kLowestBound;
  return out;
}

std::optional<HardwareOptimizer::Recommendation> HardwareOptimizer::recommended() {
  update();
  const bool model = !std::holds_alternative<std::monostate>(model_);
  std::optional<Recommendation> out;
  for (std::size_t i = 0; i < hardware_.size(); ++i) {
    const Observation& o = hardware_[i];
    if (o.failed) continue;
    const double value = model ? from_model(predict_hardware(o.x).mean) : o.y;
    if (!out || value < out->predicted) out = Recommendation{i, value};
  }
  return out;
}

HardwareModelState HardwareOptimizer::model_state() const {
  HardwareModelState s;
  s.simulation_observations = fitted_simulation_;
  s.hardware_observations = fitted_hardware_;
  s.fits = fits_;
  s.have_hyperparameters = have_hyper_;
  if (have_hyper_) s.hyperparameters = hyper_;
  s.have_simulation_fall = have_simulation_fall_;
  if (have_simulation_fall_) s.simulation_fall_hyperparameters = simulation_fall_hyper_;
  s.have_hardware_fall = have_hardware_fall_;
  if (have_hardware_fall_) s.hardware_fall_hyperparameters = hardware_fall_hyper_;
  return s;
}

HardwareOptimizer HardwareOptimizer::restore(SearchSpace space, HardwareOptimizerOptions options,
                                             const std::vector<Observation>& simulation,
                                             const std::vector<Observation>& hardware, const HardwareModelState& state,
                                             const std::vector<bool>& simulation_enqueued) {
  HardwareOptimizer opt(std::move(space), options);
  if (!simulation_enqueued.empty() && simulation_enqueued.size() != simulation.size()) {
    throw InputError(fmt::format("restore: {} enqueued flags for {} simulated observations", simulation_enqueued.size(),
                                 simulation.size()));
  }
  if (state.simulation_observations < 0 || state.simulation_observations > static_cast<int>(simulation.size()) ||
      state.hardware_observations < 0 || state.hardware_observations > static_cast<int>(hardware.size())) {
    throw InputError(fmt::format("hardware model state of {} simulated and {} hardware observations does not fit {} and {} "
                                 "stored observations",
                                 state.simulation_observations, state.hardware_observations, simulation.size(),
                                 hardware.size()));
  }
  const int d = opt.space_.size();
  const int expected = options.strategy == HardwareStrategy::kMultiFidelity ? 2 * d + 5 : 2 * d + 4;
  if (state.have_hyperparameters && state.hyperparameters.size() != expected) {
    throw InputError(fmt::format("hardware model state has {} hyperparameters, {} in {} dimensions needs {}",
                                 state.hyperparameters.size(), to_string(options.strategy), d, expected));
  }
  for (const auto* fall : {&state.simulation_fall_hyperparameters, &state.hardware_fall_hyperparameters}) {
    if (fall->size() != 0 && fall->size() != d + 2) {
      throw InputError(fmt::format("hardware model state has {} fall-model hyperparameters, {} dimensions need {}",
                                   fall->size(), d, d + 2));
    }
  }
  for (std::size_t i = 0; i < simulation.size(); ++i) {
    opt.tell_simulation(simulation[i], !simulation_enqueued.empty() && simulation_enqueued[i]);
  }
  for (const auto& o : hardware) opt.tell_hardware(o);
  opt.fits_ = state.fits;
  opt.have_hyper_ = state.have_hyperparameters;
  opt.hyper_ = state.hyperparameters;
  opt.have_simulation_fall_ = state.have_simulation_fall;
  opt.simulation_fall_hyper_ = state.simulation_fall_hyperparameters;
  opt.have_hardware_fall_ = state.have_hardware_fall;
  opt.hardware_fall_hyper_ = state.hardware_fall_hyperparameters;
  if (opt.have_hyper_) {
    // The models the last fit left, factorised once with its hyperparameters; observations after those
    // are fitted for at the next ask, as the original would.
    opt.fitted_simulation_ = state.simulation_observations;
    opt.fitted_hardware_ = state.hardware_observations;
    opt.fit_models(/*optimise=*/false);
  }
  return opt;
}

}  // namespace cpgmatch::bo
