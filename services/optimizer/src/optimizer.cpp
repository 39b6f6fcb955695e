#include "cpgmatch/bo/optimizer.hpp"

#include <algorithm>
#include <cmath>
#include <exception>
#include <future>
#include <limits>
#include <numeric>

#include <fmt/format.h>
#include <nlopt.hpp>

#include "cpgmatch/errors.hpp"

namespace cpgmatch::bo {
namespace {

constexpr Acquisition kPortfolio[3] = {Acquisition::kExpectedImprovement, Acquisition::kLowerConfidenceBound,
                                       Acquisition::kProbabilityOfImprovement};
enum Purpose : std::uint64_t { kAskPurpose = 1, kTellPurpose = 2, kFitPurpose = 3, kFallFitPurpose = 4 };

// The k rows of (X, y) nearest (unit cube) the row of the lowest y (the first of equals), in their original
// order; ties in distance go to the earlier row, so the choice is the same on every machine.
std::vector<int> rows_nearest_best(const Eigen::MatrixXd& X, const Eigen::VectorXd& y, int k) {
  Eigen::Index best = 0;
  y.minCoeff(&best);
  const Eigen::VectorXd d2 = (X.rowwise() - X.row(best)).rowwise().squaredNorm();
  std::vector<int> order(static_cast<std::size_t>(X.rows()));
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return d2[a] < d2[b]; });
  order.resize(static_cast<std::size_t>(std::min<Eigen::Index>(k, X.rows())));
  std::sort(order.begin(), order.end());
  return order;
}

// The scale GaussianProcess::fit() standardises y by (population standard deviation; 1 when constant).
double standard_scale(const Eigen::VectorXd& y) {
  const double mean = y.mean();
  const double var = y.size() > 1 ? (y.array() - mean).square().sum() / static_cast<double>(y.size()) : 0.0;
  return var > 1e-300 ? std::sqrt(var) : 1.0;
}

// Hyperparameters fitted to data standardised by `from` for data standardised by `to`: the amplitude and
// the noise are variances in standardised units, the length scales do not depend on the scale.
GpHyperparameters rescaled(GpHyperparameters h, double from, double to) {
  const double shift = 2.0 * (std::log(from) - std::log(to));
  h.log_amplitude += shift;
  h.log_noise += shift;
  return h;
}

}  // namespace

std::string to_string(LiarStrategy s) {
  switch (s) {
    case LiarStrategy::kBeliever: return "believer";
    case LiarStrategy::kMin: return "min";
    case LiarStrategy::kMean: return "mean";
    case LiarStrategy::kMax: return "max";
  }
  return "?";
}

LiarStrategy liar_from_string(std::string_view name) {
  if (name == "believer" || name == "kriging_believer") return LiarStrategy::kBeliever;
  if (name == "min" || name == "cl_min") return LiarStrategy::kMin;
  if (name == "mean" || name == "cl_mean") return LiarStrategy::kMean;
  if (name == "max" || name == "cl_max") return LiarStrategy::kMax;
  throw InputError(fmt::format("unknown liar strategy '{}' (known: believer, min, mean, max)", name));
}

std::string to_string(CostTransform t) { return t == CostTransform::kLog ? "log" : "none"; }

CostTransform cost_transform_from_string(std::string_view name) {
  if (name == "none") return CostTransform::kNone;
  if (name == "log") return CostTransform::kLog;
  throw InputError(fmt::format("unknown cost transform '{}' (known: none, log)", name));
}

void OptimizerOptions::validate() const {
  if (initial_points < 1) throw InputError(fmt::format("initial_points must be >= 1, got {}", initial_points));
  if (budget < 0) throw InputError(fmt::format("budget must be >= 0 (0: no limit), got {}", budget));
  if (!(xi >= 0.0) || !std::isfinite(xi)) throw InputError("xi must be a finite number >= 0");
  if (!(kappa >= 0.0) || !std::isfinite(kappa)) throw InputError("kappa must be a finite number >= 0");
  if (!(hedge_eta > 0.0) || !std::isfinite(hedge_eta)) throw InputError("hedge_eta must be > 0");
  if (acquisition_candidates < 1) throw InputError("acquisition_candidates must be >= 1");
  if (acquisition_local_starts < 0) throw InputError("acquisition_local_starts must be >= 0");
  if (hyperparameter_restart_every < 1) throw InputError("hyperparameter_restart_every must be >= 1");
  if (hyperparameter_max_points < 0) throw InputError("hyperparameter_max_points must be >= 0 (0: all points)");
  if (max_model_points < 0) throw InputError("max_model_points must be >= 0 (0: all points)");
  if (batch_refined_points < 0) throw InputError("batch_refined_points must be >= 0 (0: every point)");
  if (!(hyperparameter_growth >= 0.0) || !std::isfinite(hyperparameter_growth)) {
    throw InputError("hyperparameter_growth must be a finite number >= 0");
  }
}

Eigen::Vector3d HedgeState::probabilities() const {
  const Eigen::Vector3d logits = eta * (gains.array() - gains.maxCoeff()).matrix();
  const Eigen::Vector3d e = logits.array().exp();
  return e / e.sum();
}

BayesianOptimizer::BayesianOptimizer(SearchSpace space, OptimizerOptions options)
    : space_(std::move(space)), options_(options), gp_(options.gp), fall_(options.gp) {
  options_.validate();
  design_ = feasible_design();
  hedge_.eta = options_.hedge_eta;
  region_lo_ = Eigen::VectorXd::Zero(space_.size());
  region_hi_ = Eigen::VectorXd::Ones(space_.size());
}

std::mt19937_64 BayesianOptimizer::rng_for(std::uint64_t counter, std::uint64_t purpose) const {
  std::seed_seq seq{static_cast<std::uint32_t>(options_.seed), static_cast<std::uint32_t>(options_.seed >> 32),
                    static_cast<std::uint32_t>(counter), static_cast<std::uint32_t>(purpose)};
  return std::mt19937_64(seq);
}

int BayesianOptimizer::num_successful() const {
  return static_cast<int>(std::count_if(observations_.begin(), observations_.end(),
                                        [](const Observation& o) { return !o.failed; }));
}

std::optional<Observation> BayesianOptimizer::best() const {
  std::optional<Observation> out;
  for (const auto& o : observations_) {
    if (!o.failed && (!out || o.y < out->y)) out = o;
  }
  return out;
}

BayesianOptimizer::Dataset BayesianOptimizer::dataset() const {
  double worst = -std::numeric_limits<double>::infinity();
  for (const auto& o : observations_) if (!o.failed) worst = std::max(worst, o.y);
  Dataset d;
  const int n = static_cast<int>(std::count_if(observations_.begin(), observations_.end(),
                                               [](const Observation& o) { return !o.excluded; }));
  d.X.resize(n, space_.size());
  d.y.resize(n);
  int row = 0;
  for (const Observation& o : observations_) {
    if (o.excluded) continue;
    d.X.row(row) = space_.to_unit(o.x).transpose();
    d.y[row++] = to_model(o.failed ? worst : o.y);
  }
  return d;
}

BayesianOptimizer::Dataset BayesianOptimizer::model_dataset() const {
  Dataset all = dataset();
  const int cap = options_.max_model_points;
  if (cap <= 0 || all.X.rows() <= cap) return all;
  const std::vector<int> rows = rows_nearest_best(all.X, all.y, cap);
  Dataset local;
  local.X = all.X(rows, Eigen::all);
  local.y = all.y(rows);
  return local;
}

void BayesianOptimizer::set_region(const Dataset& model_data) {
  const int d = space_.size();
  region_lo_ = Eigen::VectorXd::Zero(d);
  region_hi_ = Eigen::VectorXd::Ones(d);
  // The whole cube unless the model is local (and constraints search the whole cube: their feasible
  // region is drawn by rejection there).
  const int cap = options_.max_model_points;
  if (cap <= 0 || model_data.X.rows() < cap || constrained()) return;
  // The box of the local model's points, widened by a tenth of its size on each side (the next better
  // point may lie just outside what was sampled), within the cube.
  const Eigen::VectorXd lo = model_data.X.colwise().minCoeff(), hi = model_data.X.colwise().maxCoeff();
  const Eigen::VectorXd pad = (0.1 * (hi - lo)).cwiseMax(1e-3);
  region_lo_ = (lo - pad).cwiseMax(0.0);
  region_hi_ = (hi + pad).cwiseMin(1.0);
}

double BayesianOptimizer::to_model(double cost) const {
  return options_.cost_transform == CostTransform::kLog ? std::log(cost) : cost;
}

double BayesianOptimizer::from_model(double value) const {
  return options_.cost_transform == CostTransform::kLog ? std::exp(value) : value;
}

void BayesianOptimizer::check_cost(double y, const char* where) const {
  if (!std::isfinite(y)) {
    throw InputError(fmt::format("{}: cost must be a finite number, got {} (use tell_failure for failed evaluations)", where, y));
  }
  if (options_.cost_transform == CostTransform::kLog && !(y > 0.0)) {
    throw InputError(fmt::format("{}: cost must be > 0 with cost_transform log, got {}", where, y));
  }
}

void BayesianOptimizer::tell(const Eigen::VectorXd& x, double y, bool fell) {
  space_.check_point(x);
  check_cost(y, "tell");
  record({x, y, false, fell});
}

void BayesianOptimizer::tell_failure(const Eigen::VectorXd& x) {
  space_.check_point(x);
  record({x, 0.0, true});
}

void BayesianOptimizer::tell_batch(const std::vector<Observation>& batch) {
  for (const auto& o : batch) {
    space_.check_point(o.x);
    if (o.excluded && !o.failed) throw InputError("tell_batch: an excluded observation must be a failed one");
    if (!o.failed) check_cost(o.y, "tell_batch");
  }
  if (batch.empty()) return;
  observations_.insert(observations_.end(), batch.begin(), batch.end());
  if (model_due()) refit();
}

bool BayesianOptimizer::model_due() const {
  // The model is first used once the initial design has been evaluated (and needs two real values), and
  // is not needed once the budget is spent.
  const int n = static_cast<int>(observations_.size());
  if (options_.budget > 0 && n >= options_.budget) return false;
  return n >= options_.initial_points && num_successful() >= 2;
}

void BayesianOptimizer::record(Observation obs) {
  observations_.push_back(std::move(obs));
  if (model_due()) refit();
}

bool BayesianOptimizer::hyperparameters_due() const {
  if (!have_hyper_) return true;
  const int n = static_cast<int>(observations_.size());
  const int step = std::max(1, static_cast<int>(std::floor(options_.hyperparameter_growth * optimised_observations_)));
  return n >= optimised_observations_ + step;
}

void BayesianOptimizer::refit() {
  const Dataset data = model_dataset();
  set_region(data);
  auto fit_rng = rng_for(observations_.size(), kFitPurpose);
  const bool optimise = hyperparameters_due();
  if (optimise) {
    GpOptions gp_options = options_.gp;
    const bool restart = !have_hyper_ || fits_ % options_.hyperparameter_restart_every == 0;
    if (!restart) {
      gp_options.random_restarts = 0;
      gp_options.max_evaluations = options_.hyperparameter_warm_evaluations;
    }
    const int cap = options_.hyperparameter_max_points;
    if (cap > 0 && data.X.rows() > cap) {
      // Optimised on `cap` points spread evenly over the data in order (each likelihood evaluation O(cap^3);
      // the points nearest the best gave local length scales that kept 2 of 5 seeds of hartmann6 in its
      // local minimum at budget 1000 batch 100, the spread subset none), then carried over
      // to the whole data's standardisation; warm-started from the last ones carried back.
      std::vector<int> rows(static_cast<std::size_t>(cap));
      for (int i = 0; i < cap; ++i) rows[static_cast<std::size_t>(i)] = static_cast<int>(static_cast<long>(i) * data.X.rows() / cap);
      const Eigen::MatrixXd Xs = data.X(rows, Eigen::all);
      const Eigen::VectorXd ys = data.y(rows);
      const double full_scale = standard_scale(data.y), subset_scale = standard_scale(ys);
      const GpHyperparameters start = rescaled(last_hyper_, full_scale, subset_scale);
      GaussianProcess subset(gp_options);
      subset.fit(Xs, ys, true, fit_rng, have_hyper_ ? &start : nullptr);
      last_hyper_ = rescaled(subset.hyperparameters(), subset_scale, full_scale);
      gp_ = GaussianProcess(options_.gp);
      gp_.fit(data.X, data.y, false, fit_rng, &last_hyper_);
    } else {
      gp_ = GaussianProcess(gp_options);
      gp_.fit(data.X, data.y, true, fit_rng, have_hyper_ ? &last_hyper_ : nullptr);
      last_hyper_ = gp_.hyperparameters();
    }
    have_hyper_ = true;
    optimised_observations_ = static_cast<int>(observations_.size());
  } else {
    // The hyperparameters held: one factorisation (what restore() does with the saved ones, bit for bit).
    gp_ = GaussianProcess(options_.gp);
    gp_.fit(data.X, data.y, false, fit_rng, &last_hyper_);
  }
  // A first fall has no fall hyperparameters to hold: they are optimised whatever the schedule.
  fit_fall_model(optimise || !have_fall_hyper_);
  if (optimise) ++fits_;
  fitted_observations_ = static_cast<int>(observations_.size());

  // gp_hedge: reward each acquisition by minus the new model's mean at its previous proposal
  // (in objective units, never reset or decayed: scikit-optimize's semantics).
  if (options_.acquisition == Acquisition::kHedge && next_proposals_.size() == 3) {
    for (int a = 0; a < 3; ++a) hedge_.gains[a] -= gp_.predict(next_proposals_[a]).mean;
  }
  propose(data);
}

void BayesianOptimizer::fit_fall_model(bool optimise) {
  if (!options_.fall_model) return;
  std::vector<bool> fell;
  std::vector<int> rows;
  double level = 0.0;
  int falls = 0;
  for (std::size_t i = 0; i < observations_.size(); ++i) {
    const Observation& o = observations_[i];
    if (o.failed) continue;  // a crashed evaluation says nothing about falling
    rows.push_back(static_cast<int>(i));
    fell.push_back(o.fell);
    if (o.fell) {
      level += to_model(o.y);
      ++falls;
    }
  }
  Eigen::MatrixXd X(static_cast<Eigen::Index>(rows.size()), space_.size());
  for (std::size_t r = 0; r < rows.size(); ++r) X.row(static_cast<Eigen::Index>(r)) = space_.to_unit(observations_[rows[r]].x).transpose();
  fall_level_ = falls > 0 ? level / falls : 0.0;
  // Same schedule as the cost GP: warm-started every fit, random restarts every k-th fit.
  GpOptions fall_options = options_.gp;
  const bool restart = !have_fall_hyper_ || fits_ % options_.hyperparameter_restart_every == 0;
  if (optimise && !restart) {
    fall_options.random_restarts = 0;
    fall_options.max_evaluations = options_.hyperparameter_warm_evaluations;
  }
  fall_ = FallModel(fall_options);
  auto rng = rng_for(observations_.size(), kFallFitPurpose);
  fall_.fit(X, fell, optimise, rng, have_fall_hyper_ ? &last_fall_hyper_ : nullptr);
  if (optimise && fall_.active()) {
    last_fall_hyper_ = fall_.hyperparameters();
    have_fall_hyper_ = true;
  }
}

void BayesianOptimizer::propose(const Dataset& data) {
  const double y_best = data.y.minCoeff();
  auto rng = rng_for(observations_.size(), kTellPurpose);
  if (options_.acquisition == Acquisition::kHedge) {
    next_proposals_ = optimise_acquisitions({std::begin(kPortfolio), std::end(kPortfolio)}, y_best, rng);
  } else {
    next_proposals_ = optimise_acquisitions({options_.acquisition}, y_best, rng);
  }
}

// Runs task(0..count-1), on `threads` threads (this one included); each task must only write its own
// results. With one thread, in order on this thread.
template <typename Task>
void run_tasks(int count, int threads, const Task& task) {
  threads = std::clamp(threads, 1, std::max(count, 1));
  if (threads == 1) {
    for (int i = 0; i < count; ++i) task(i);
    return;
  }
  std::vector<std::future<void>> helpers;
  for (int t = 1; t < threads; ++t) {
    helpers.push_back(std::async(std::launch::async, [&, t] {
      for (int i = t; i < count; i += threads) task(i);
    }));
  }
  std::exception_ptr error;
  try {
    for (int i = 0; i < count; i += threads) task(i);
  } catch (...) {
    error = std::current_exception();
  }
  for (auto& h : helpers) {
    try {
      h.get();
    } catch (...) {
      if (!error) error = std::current_exception();
    }
  }
  if (error) std::rethrow_exception(error);
}

// The candidates' posterior in this many column blocks, whatever the number of threads that compute them:
// the result (to the last bit) does not depend on the threads.
constexpr int kCandidateBlocks = 2;

BayesianOptimizer::Candidates BayesianOptimizer::draw_candidates(std::mt19937_64& rng, int m) const {
  const int d = space_.size();
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  Candidates c;
  c.C.resize(d, m);
  c.taken.assign(static_cast<std::size_t>(m), false);
  if (constrained()) {
    for (int j = 0; j < m; ++j) c.C.col(j) = random_unit_point(rng);
  } else {
    // Within the model's region (the whole cube: lo 0, width 1, the same numbers as plain unit draws).
    const Eigen::VectorXd width = region_hi_ - region_lo_;
    for (int j = 0; j < m; ++j)
      for (int i = 0; i < d; ++i) c.C(i, j) = region_lo_[i] + unit(rng) * width[i];
  }
  compute_posterior(c);
  c.p_safe = fall_.probability_safe_many(c.C);  // all 1 while there is no fall model; lies do not change it
  return c;
}

void BayesianOptimizer::compute_posterior(Candidates& c) const {
  const long m = c.C.cols();
  c.blocks.assign(kCandidateBlocks, CandidatePosterior{});
  run_tasks(kCandidateBlocks, threads_, [&](int b) {
    const long first = m * b / kCandidateBlocks, last = m * (b + 1) / kCandidateBlocks;
    c.blocks[static_cast<std::size_t>(b)] = gp_.candidate_posterior(c.C.middleCols(first, last - first));
  });
}

void BayesianOptimizer::extend_posterior(Candidates& c) const {
  run_tasks(kCandidateBlocks, threads_, [&](int b) { gp_.extend(c.blocks[static_cast<std::size_t>(b)]); });
}

std::vector<Eigen::VectorXd> BayesianOptimizer::optimise_acquisitions(const std::vector<Acquisition>& acquisitions,
                                                                      double y_best, std::mt19937_64& rng) const {
  return refine_acquisitions(acquisitions, y_best, draw_candidates(rng, options_.acquisition_candidates));
}

Eigen::VectorXd BayesianOptimizer::thompson_candidate(Candidates& c, std::mt19937_64& rng) const {
  // A draw of f at every candidate from its posterior marginal: mean + std z is the lower confidence bound
  // with kappa = -z, so the fall-weighted form is LCB's (the draw if the point stands, the falls' cost if not).
  std::normal_distribution<double> normal(0.0, 1.0);
  int best = -1;
  double best_value = std::numeric_limits<double>::infinity();
  for (int b = 0, first = 0; b < kCandidateBlocks; ++b) {
    const CandidatePosterior& block = c.blocks[static_cast<std::size_t>(b)];
    Eigen::VectorXd mean, std;
    gp_.predict_candidates(block, &mean, &std);
    for (int j = 0; j < mean.size(); ++j) {
      const double z = normal(rng);  // drawn for taken candidates too: the same draws whatever was taken
      if (c.taken[static_cast<std::size_t>(first + j)]) continue;
      const double p = std::clamp(c.p_safe[first + j], 0.0, 1.0);
      const double v = LowerConfidenceBound::safe(mean[j], std[j], p, fall_level_, {0.0, 0.0, -z}).value;
      if (v < best_value) {
        best_value = v;
        best = first + j;
      }
    }
    first += static_cast<int>(block.C.cols());
  }
  if (best < 0) return c.C.col(0);  // every candidate taken: the caller's duplicate check draws a random point
  c.taken[static_cast<std::size_t>(best)] = true;
  return c.C.col(best);
}

std::vector<Eigen::VectorXd> BayesianOptimizer::refine_acquisitions(const std::vector<Acquisition>& acquisitions,
                                                                    double y_best, const Candidates& candidates) const {
  const int d = space_.size();
  const Eigen::MatrixXd& C = candidates.C;
  const Eigen::VectorXd& p_safe = candidates.p_safe;
  const int m = static_cast<int>(C.cols());
  Eigen::VectorXd mean(m), std(m);
  for (int b = 0, first = 0; b < kCandidateBlocks; ++b) {
    const CandidatePosterior& block = candidates.blocks[static_cast<std::size_t>(b)];
    const int size = static_cast<int>(block.C.cols());
    Eigen::VectorXd mb, sb;
    gp_.predict_candidates(block, &mb, &sb);
    mean.segment(first, size) = mb;
    std.segment(first, size) = sb;
    first += size;
  }

  struct Context {
    const BayesianOptimizer* self;
    Acquisition a;
    double y_best;
  };
  auto objective = [](unsigned n, const double* x, double* g, void* data) -> double {
    const auto* c = static_cast<const Context*>(data);
    const Eigen::Map<const Eigen::VectorXd> u(x, n);
    Eigen::VectorXd dmean, dstd;
    const Prediction p = c->self->gp_.predict_with_gradient(u, g ? &dmean : nullptr, g ? &dstd : nullptr);
    const SafeProbability safe = g ? c->self->fall_.probability_safe_with_gradient(u)
                                   : SafeProbability{c->self->fall_.probability_safe(u), {}};
    const SafeAcquisitionValue v = evaluate_safe_acquisition(c->a, p.mean, p.std, safe.p, c->self->fall_level_, c->y_best,
                                                             c->self->options_.xi, c->self->options_.kappa);
    if (g) {
      for (unsigned i = 0; i < n; ++i) {
        const double gi = v.d_mean * dmean[i] + v.d_std * dstd[i] + v.d_p * safe.dp_dx[i];
        g[i] = std::isfinite(gi) ? gi : 0.0;
      }
    }
    return std::isfinite(v.value) ? v.value : 1e300;
  };
  auto score_at = [&](Acquisition a, const Prediction& p, double p_safe_here) {
    return evaluate_safe_acquisition(a, p.mean, p.std, p_safe_here, fall_level_, y_best, options_.xi, options_.kappa).value;
  };

  // Every acquisition's starting points (its best candidates), then every local refinement, independent
  // of each other (run in parallel when threads_ > 1), then each acquisition's best, in start order.
  const int starts = std::min(options_.acquisition_local_starts, m);
  const int na = static_cast<int>(acquisitions.size());
  std::vector<std::vector<int>> orders(na);
  std::vector<std::vector<double>> scores(na);
  for (int k = 0; k < na; ++k) {
    const Acquisition a = acquisitions[k];
    std::vector<double>& score = scores[k];
    score.resize(m);
    for (int j = 0; j < m; ++j) score[j] = score_at(a, Prediction{mean[j], std[j]}, p_safe[j]);
    std::vector<int>& order = orders[k];
    order.resize(m);
    std::iota(order.begin(), order.end(), 0);
    std::partial_sort(order.begin(), order.begin() + std::max(starts, 1), order.end(),
                      [&](int l, int r) { return score[l] < score[r]; });
  }
  struct Refined {
    Eigen::VectorXd x;
    double value = 0.0;
  };
  std::vector<Refined> refined(static_cast<std::size_t>(na * starts));
  run_tasks(na * starts, threads_, [&](int task) {
    const int k = task / starts, s = task % starts;
    const Acquisition a = acquisitions[k];
    Context ctx{this, a, y_best};
    nlopt::opt opt(nlopt::LD_LBFGS, static_cast<unsigned>(d));
    opt.set_lower_bounds(std::vector<double>(region_lo_.data(), region_lo_.data() + d));
    opt.set_upper_bounds(std::vector<double>(region_hi_.data(), region_hi_.data() + d));
    opt.set_min_objective(objective, &ctx);
    opt.set_maxeval(options_.acquisition_local_evaluations);
    opt.set_xtol_abs(1e-9);
    const Eigen::VectorXd start = C.col(orders[k][s]);
    std::vector<double> x(start.data(), start.data() + d);
    double value = scores[k][orders[k][s]];
    try {
      opt.optimize(x, value);
    } catch (const std::exception&) {
      // Roundoff-limited stop: keep whatever point NLopt left in x, re-scored here.
      const Eigen::Map<const Eigen::VectorXd> u(x.data(), d);
      value = score_at(a, gp_.predict(u), fall_.probability_safe(u));
    }
    Eigen::VectorXd end = Eigen::Map<Eigen::VectorXd>(x.data(), d).cwiseMax(region_lo_).cwiseMin(region_hi_);
    if (!feasible_unit(end)) {
      // L-BFGS knows the box only: a refinement that left the feasible region stops at its boundary.
      end = feasible_towards(start, end);
      value = score_at(a, gp_.predict(end), fall_.probability_safe(end));
    }
    refined[static_cast<std::size_t>(task)] = {end, value};
  });

  std::vector<Eigen::VectorXd> proposals;
  for (int k = 0; k < na; ++k) {
    Eigen::VectorXd best_x = C.col(orders[k][0]);
    double best_value = scores[k][orders[k][0]];
    for (int s = 0; s < starts; ++s) {
      const Refined& r = refined[static_cast<std::size_t>(k * starts + s)];
      if (std::isfinite(r.value) && r.value < best_value) {
        best_value = r.value;
        best_x = r.x.cwiseMax(region_lo_).cwiseMin(region_hi_);
      }
    }
    proposals.push_back(best_x);
  }
  return proposals;
}

bool BayesianOptimizer::is_duplicate(const Eigen::VectorXd& u, const Eigen::MatrixXd& taken) const {
  for (int i = 0; i < taken.rows(); ++i) {
    if ((taken.row(i).transpose() - u).norm() < 1e-6) return true;
  }
  return false;
}

Eigen::VectorXd BayesianOptimizer::random_unit_point(std::mt19937_64& rng) const {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  Eigen::VectorXd u(space_.size());
  // Rejection: a constraint set that leaves less than 1e-5 of the box is refused rather than searched.
  constexpr int kMaxDraws = 100'000;
  for (int draw = 0; draw < kMaxDraws; ++draw) {
    for (int i = 0; i < u.size(); ++i) u[i] = unit(rng);
    if (feasible_unit(u)) return u;
  }
  throw InputError(fmt::format("constraints: no feasible point in {} random draws; the constraints leave (almost) "
                               "nothing of the search space",
                               kMaxDraws));
}

Eigen::MatrixXd BayesianOptimizer::feasible_design() const {
  const int n = options_.initial_points, d = space_.size();
  if (!constrained()) return make_initial_design(options_.initial_design, n, d, options_.seed);
  // A longer design of the same kind, its infeasible points dropped, in order: the design's own spread
  // over what is left of the box (deterministic in the seed).
  for (long m = n; m <= 4096L * n; m *= 2) {
    const Eigen::MatrixXd all = make_initial_design(options_.initial_design, static_cast<int>(m), d, options_.seed);
    Eigen::MatrixXd kept(n, d);
    int k = 0;
    for (int r = 0; r < all.rows() && k < n; ++r) {
      if (feasible_unit(all.row(r).transpose())) kept.row(k++) = all.row(r);
    }
    if (k == n) return kept;
  }
  throw InputError(fmt::format("constraints: fewer than {} feasible points among {} of the initial design; the "
                               "constraints leave (almost) nothing of the search space",
                               n, 4096L * n));
}

Eigen::VectorXd BayesianOptimizer::feasible_towards(const Eigen::VectorXd& inside, const Eigen::VectorXd& outside) const {
  double lo = 0.0, hi = 1.0;  // inside + t (outside - inside) is feasible at lo, not at hi
  for (int step = 0; step < 30; ++step) {
    const double mid = 0.5 * (lo + hi);
    (feasible_unit(inside + mid * (outside - inside)) ? lo : hi) = mid;
  }
  return inside + lo * (outside - inside);
}

std::vector<Eigen::VectorXd> BayesianOptimizer::ask(int n, const std::vector<Eigen::VectorXd>& pending) {
  if (n < 0) throw InputError("ask: n must be >= 0");
  for (const auto& p : pending) space_.check_point(p);
  std::vector<Eigen::VectorXd> out;
  int issued = static_cast<int>(observations_.size() + pending.size());
  // Initial design first: row k of the design is the k-th point ever issued.
  while (static_cast<int>(out.size()) < n && issued < options_.initial_points) {
    out.push_back(space_.from_unit(design_.row(issued).transpose()));
    ++issued;
  }
  if (static_cast<int>(out.size()) == n) return out;

  std::vector<Eigen::VectorXd> busy = pending;
  busy.insert(busy.end(), out.begin(), out.end());
  if (!model_ready()) {
    // Design exhausted by in-flight points but too few results for a model: seeded random points.
    auto rng = rng_for(issued, kAskPurpose);
    while (static_cast<int>(out.size()) < n) out.push_back(space_.from_unit(random_unit_point(rng)));
    return out;
  }
  const auto more = ask_model(n - static_cast<int>(out.size()), busy, issued);
  out.insert(out.end(), more.begin(), more.end());
  return out;
}

std::vector<Eigen::VectorXd> BayesianOptimizer::ask_model(int n, const std::vector<Eigen::VectorXd>& busy, int issued) {
  Dataset data = model_dataset();
  const double constant_lie = options_.liar == LiarStrategy::kMin    ? data.y.minCoeff()
                              : options_.liar == LiarStrategy::kMean ? data.y.mean()
                                                                     : data.y.maxCoeff();
  // The believer asks the working model (which already holds the earlier lies of this ask) for its mean.
  auto append = [&](const Eigen::VectorXd& u) {
    const double lie = options_.liar == LiarStrategy::kBeliever ? gp_.predict(u).mean : constant_lie;
    data.X.conservativeResize(data.X.rows() + 1, Eigen::NoChange);
    data.X.row(data.X.rows() - 1) = u.transpose();
    data.y.conservativeResize(data.y.size() + 1);
    data.y[data.y.size() - 1] = lie;
  };
  for (const auto& p : busy) append(space_.to_unit(p));

  // The fitted model stays the reference for the hedge; lies go into a working copy, whose Cholesky factor
  // is extended by each batch of lies (GaussianProcess::append_fixed) rather than recomputed.
  const GaussianProcess fitted = gp_;
  const bool lies_present = !busy.empty();
  const int nb = static_cast<int>(busy.size());
  if (lies_present) gp_.append_fixed(data.X.bottomRows(nb), data.y.tail(nb));

  std::vector<Eigen::VectorXd> out;
  auto rng = rng_for(issued, kAskPurpose);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  // One candidate set for the whole ask: each chosen point's lie adds a row to their posterior
  // (extend_posterior) instead of a fresh kernel and triangular solve over every point per point.
  std::optional<Candidates> candidates;
  for (int k = 0; k < n; ++k) {
    int choice = 0;
    if (options_.acquisition == Acquisition::kHedge) {
      const Eigen::Vector3d p = hedge_.probabilities();
      const double r = unit(rng);
      choice = r < p[0] ? 0 : (r < p[0] + p[1] ? 1 : 2);
    }
    const Acquisition a = options_.acquisition == Acquisition::kHedge ? kPortfolio[choice] : options_.acquisition;
    Eigen::VectorXd u;
    if (k == 0 && !lies_present) {
      u = next_proposals_[choice];  // computed at the last tell, exactly as scikit-optimize's ask()
    } else {
      const int refined = options_.batch_refined_points;
      const bool large = refined > 0 && n > refined;
      if (!candidates) {
        // A large batch draws 10 candidates per point, so that its unrefined points still choose.
        const int m = large ? std::clamp(10 * n, options_.acquisition_candidates, 20000) : options_.acquisition_candidates;
        candidates = draw_candidates(rng, m);
      }
      if (large && k >= refined) u = thompson_candidate(*candidates, rng);
      else u = refine_acquisitions({a}, data.y.minCoeff(), *candidates).front();
    }
    if (is_duplicate(u, data.X)) u = random_unit_point(rng);
    out.push_back(space_.from_unit(u));
    append(u);
    if (k + 1 < n) {
      const bool extended = gp_.append_fixed(data.X.bottomRows(1), data.y.tail(1));
      if (candidates && extended) extend_posterior(*candidates);
      if (candidates && !extended) compute_posterior(*candidates);  // refactorised: earlier rows changed
    }
  }
  gp_ = fitted;
  return out;
}

std::optional<BayesianOptimizer::Recommendation> BayesianOptimizer::recommended() const {
  std::optional<Recommendation> out;
  for (std::size_t i = 0; i < observations_.size(); ++i) {
    const Observation& o = observations_[i];
    if (o.failed) continue;
    const double value = gp_.fitted() ? from_model(gp_.predict(space_.to_unit(o.x)).mean) : o.y;
    if (!out || value < out->predicted) out = Recommendation{i, value};
  }
  return out;
}

ModelState BayesianOptimizer::model_state() const {
  ModelState s;
  s.observations = static_cast<int>(observations_.size());
  s.fits = fits_;
  s.have_hyperparameters = have_hyper_;
  if (have_hyper_) s.hyperparameters = last_hyper_.pack();
  s.hedge_gains = hedge_.gains;
  s.fitted_observations = fitted_observations_;
  s.optimised_observations = optimised_observations_;
  s.have_fall_hyperparameters = have_fall_hyper_;
  if (have_fall_hyper_) s.fall_hyperparameters = last_fall_hyper_.pack();
  return s;
}

BayesianOptimizer BayesianOptimizer::restore(SearchSpace space, OptimizerOptions options,
                                             const std::vector<Observation>& observations, const ModelState& state) {
  if (state.observations < 0 || state.observations > static_cast<int>(observations.size())) {
    throw InputError(fmt::format("model state of {} observations does not fit {} stored observations", state.observations,
                                 observations.size()));
  }
  BayesianOptimizer opt(std::move(space), options);
  if (state.have_hyperparameters && state.hyperparameters.size() != opt.space_.size() + 2) {
    throw InputError(fmt::format("model state has {} hyperparameters, a {}-dimensional space needs {}",
                                 state.hyperparameters.size(), opt.space_.size(), opt.space_.size() + 2));
  }
  for (int i = 0; i < state.observations; ++i) {
    opt.space_.check_point(observations[i].x);
    opt.observations_.push_back(observations[i]);  // no refit: the state says what the fits gave
  }
  opt.fits_ = state.fits;
  opt.fitted_observations_ = state.fitted_observations >= 0 ? state.fitted_observations : state.observations;
  // A store from before the schedule optimised at every fit: its latest optimisation is its latest fit.
  opt.optimised_observations_ = state.optimised_observations >= 0 ? state.optimised_observations : opt.fitted_observations_;
  opt.have_hyper_ = state.have_hyperparameters;
  if (opt.have_hyper_) opt.last_hyper_ = GpHyperparameters::unpack(state.hyperparameters);
  opt.hedge_.gains = state.hedge_gains;
  if (state.have_fall_hyperparameters) {
    if (state.fall_hyperparameters.size() != opt.space_.size() + 2) {
      throw InputError(fmt::format("model state has {} fall-model hyperparameters, a {}-dimensional space needs {}",
                                   state.fall_hyperparameters.size(), opt.space_.size(), opt.space_.size() + 2));
    }
    opt.have_fall_hyper_ = true;
    opt.last_fall_hyper_ = GpHyperparameters::unpack(state.fall_hyperparameters);
  }
  if (opt.model_due() && opt.have_hyper_) {
    // The GP the last fit left, factorised once with its hyperparameters (no optimisation), and the
    // proposals computed from it with the same seeded generator as then.
    const Dataset data = opt.model_dataset();
    opt.set_region(data);
    std::mt19937_64 unused(0);
    opt.gp_ = GaussianProcess(opt.options_.gp);
    opt.gp_.fit(data.X, data.y, /*optimise=*/false, unused, &opt.last_hyper_);
    if (opt.have_fall_hyper_) opt.fit_fall_model(/*optimise=*/false);
    opt.propose(data);
  }
  for (std::size_t i = state.observations; i < observations.size(); ++i) {
    if (observations[i].excluded) opt.tell_batch({observations[i]});
    else if (observations[i].failed) opt.tell_failure(observations[i].x);
    else opt.tell(observations[i].x, observations[i].y, observations[i].fell);
  }
  return opt;
}

BayesianOptimizer BayesianOptimizer::rebuild(SearchSpace space, OptimizerOptions options,
                                             const std::vector<Observation>& observations) {
  BayesianOptimizer opt(std::move(space), options);
  for (const auto& o : observations) {
    if (o.excluded) opt.tell_batch({o});
    else if (o.failed) opt.tell_failure(o.x);
    else opt.tell(o.x, o.y, o.fell);
  }
  return opt;
}

}  // namespace cpgmatch::bo
