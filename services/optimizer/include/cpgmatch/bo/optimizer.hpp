// Bayesian optimisation with an ask/tell interface, batch proposals and gp_hedge, shaped for a
// distributed service where many workers evaluate points and results arrive in any order.
//
//   BayesianOptimizer opt(space, options);
//   auto batch = opt.ask(4);                 // four distinct points for four idle workers
//   opt.tell(batch[2], 1.7);                 // results in any order
//   opt.tell_failure(batch[0]);              // a crashed or timed-out evaluation
//   auto next = opt.ask(1, {batch[1], batch[3]});   // pass the points still being evaluated
//
// State changes only in tell()/tell_failure()/tell_batch(): each one refits the GP (hyperparameters by marginal
// likelihood) and, as in scikit-optimize, optimises every acquisition of the portfolio and updates the
// gp_hedge gains with the new model's mean at the previous proposals. ask() is a pure function of that
// state and the pending points, with randomness seeded by (seed, number of points issued). Therefore
// replaying the observation list through tell() rebuilds exactly the same optimizer (rebuild()).
//
// Batches add each pending or newly chosen point to the GP with a fake result (hyperparameters kept)
// before the next point is chosen. The default is the kriging believer (Ginsbourger et al. 2010): the
// fake result is the model's own mean there, so a pending point only removes the uncertainty around it.
// The constant liars (min, mean or max of the observations) bias the mean. With asynchronous workers there
// is nearly always one pending point, the latest proposal, and the min liar declares it as good as the
// best: the acquisition then peaks right beside it, the next proposal is a small step on, and the study
// walks a path of neighbouring points whatever their results (31 consecutive rollouts in one measured study,
// tests/unit/data/walk_study_trials.csv).
//
// With fall_model on, a second GP (FallModel, fall_model.hpp) learns from the observations flagged `fell`
// where proposals fall, and every acquisition is weighted by the probability of not falling
// (evaluate_safe_acquisition). Until the first fall it changes nothing.
//
// Failed evaluations are kept and enter the GP with the worst successful cost observed so far
// (re-imputed at every fit), which pushes the search away from them without inventing a scale.
#pragma once

#include <algorithm>
#include <cstdint>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "cpgmatch/bo/acquisition.hpp"
#include "cpgmatch/bo/constraints.hpp"
#include "cpgmatch/bo/fall_model.hpp"
#include "cpgmatch/bo/gaussian_process.hpp"
#include "cpgmatch/bo/initial_design.hpp"
#include "cpgmatch/bo/search_space.hpp"

namespace cpgmatch::bo {

enum class LiarStrategy { kBeliever, kMin, kMean, kMax };

// What the GP models. kLog fits log(cost) (costs must be > 0): a cost that spans a cliff (a fall costs
// 13-19, a good gait 0.4-2) dominates a GP's amplitude in linear units, so the model's uncertainty
// everywhere unexplored dwarfs the differences between good gaits and the acquisition keeps leaving
// them; in log units a fall is ~3.5 above a good gait and a 10% improvement is 0.1 wherever it happens.
// A monotone transform leaves the minimiser unchanged; costs are stored and reported untransformed.
enum class CostTransform { kNone, kLog };
std::string to_string(CostTransform t);
CostTransform cost_transform_from_string(std::string_view name);  // "none", "log"
std::string to_string(LiarStrategy s);
LiarStrategy liar_from_string(std::string_view name);  // "believer", "min", "mean", "max" (also "cl_min", ...)

struct OptimizerOptions {
  int initial_points = 15;             // paper: 15 random rollouts before the model is used
  InitialDesign initial_design = InitialDesign::kRandom;
  Acquisition acquisition = Acquisition::kHedge;
  double xi = 0.01;                    // EI/PI exploration margin, in objective units (scikit-optimize)
  double kappa = 1.96;                 // LCB exploration weight (scikit-optimize)
  double hedge_eta = 1.0;              // softmax temperature of gp_hedge
  int acquisition_candidates = 1000;   // random points scored (once, shared by the portfolio) before refinement
  int acquisition_local_starts = 5;    // best candidates refined with L-BFGS
  int acquisition_local_evaluations = 40;
  LiarStrategy liar = LiarStrategy::kBeliever;
  CostTransform cost_transform = CostTransform::kNone;
  // Learn where evaluations fall (observations with fell = true) and weight the acquisitions by the
  // probability of not falling. Off by default for plain functions; studies switch it on (a fall is a
  // robot on the floor, whatever it costs).
  bool fall_model = false;
  std::uint64_t seed = 0;
  GpOptions gp;
  // Hyperparameters: re-optimised (warm-started L-BFGS) once the model has grown by this fraction of the
  // points it had at the last optimisation (at least one point: below 1/growth points, at every tell);
  // in between, the model is refactorised with the hyperparameters held, O(n^3/3) instead of ~20
  // likelihood evaluations of O(n^3) each. At 150 points: every 7th tell. 0: at every tell (the old
  // schedule). Random restarts at every k-th optimisation as well.
  double hyperparameter_growth = 0.05;
  int hyperparameter_restart_every = 10;
  int hyperparameter_warm_evaluations = 20;  // L-BFGS budget of a warm-started fit (restart fits: gp.max_evaluations)
  // Large studies (issue 36). Past hyperparameter_max_points model points the hyperparameters are
  // optimised on that many points spread evenly over the data (O(300^3) per likelihood evaluation instead
  // of O(n^3)), then used, rescaled to the whole data's standardisation, for the model of every point.
  int hyperparameter_max_points = 300;
  // Past max_model_points observations the model is local (a trust region, as in TuRBO, Eriksson et al.
  // 2019): the exact GP of the max_model_points observations nearest the best one, and the acquisition
  // searched only within the box of those points (elsewhere the data it does not hold is known already).
  int max_model_points = 1000;
  // A batch refines (L-BFGS) the acquisition for its first batch_refined_points points; the rest are
  // Thompson draws: the untaken candidate of the batch's candidate set (10 per point asked for, at least
  // acquisition_candidates) where a draw from the posterior marginals is lowest (the believer's lies
  // shrink the spread around points already chosen). A batch of up to this many points (the paper's
  // study) is proposed exactly as before. 0: every point refined.
  int batch_refined_points = 10;
  // Observations after which no more points will be asked for (a study's budget; 0: no limit). The model
  // is not refitted for the last one: a fit nobody will ask is pure cost (minutes on thousands of points).
  int budget = 0;
  // Constraints every proposal satisfies (constraints.hpp): the initial design keeps only its feasible
  // points (in order), the acquisition search scores and refines only feasible points, and the random
  // fallbacks draw until a point is feasible. Null or empty: the box alone, exactly as without the option.
  std::shared_ptr<const ParameterConstraints> constraints;

  // Throws InputError naming the first invalid field.
  void validate() const;
};

struct Observation {
  Eigen::VectorXd x;  // in the space's units
  double y = 0.0;     // meaningful only when !failed
  bool failed = false;
  bool fell = false;  // a successful evaluation that ended in a fall (y is its cost, still valid)
  // A failed evaluation that says nothing about its point (a robot fault, a diverged simulation, retried
  // until its bound): kept in order, so counts and saved states stay aligned, but never in the model,
  // not even as the worst cost a plain failure is imputed.
  bool excluded = false;
};

struct HedgeState {
  Eigen::Vector3d gains = Eigen::Vector3d::Zero();  // EI, LCB, PI (scikit-optimize's order)
  Eigen::Vector3d probabilities() const;             // softmax(eta * (gains - max gains))
  double eta = 1.0;
};

// What a BayesianOptimizer learned beyond its observations, after its latest fit: with the observations
// it restores the optimizer exactly (restore()), without refitting once per observation.
struct ModelState {
  int observations = 0;                 // how many observations this state belongs to
  // How many of them the latest fit covered: fewer than `observations` when the last tells did not refit
  // (the budget's last observation is never fitted: nobody will ask). -1: not known (an older store).
  // A study continued with a larger budget restores at this count and tells the rest again, so that they
  // are fitted as they would have been had the budget been larger from the start.
  int fitted_observations = -1;
  int fits = 0;                         // hyperparameter fits so far (sets when random restarts happen)
  // Observations at the latest hyperparameter optimisation (sets when the next one happens). -1: not known
  // (a store older than the schedule, when every fit optimised: fitted_observations is that count).
  int optimised_observations = -1;
  bool have_hyperparameters = false;
  Eigen::VectorXd hyperparameters;      // GpHyperparameters::pack() of the latest fit
  Eigen::Vector3d hedge_gains = Eigen::Vector3d::Zero();
  bool have_fall_hyperparameters = false;  // the fall model's latest fit (fall_model on, falls seen)
  Eigen::VectorXd fall_hyperparameters;
};

class BayesianOptimizer {
 public:
  BayesianOptimizer(SearchSpace space, OptimizerOptions options);

  // n distinct points, avoiding `pending` (points issued but not yet told), in the space's units.
  std::vector<Eigen::VectorXd> ask(int n, const std::vector<Eigen::VectorXd>& pending = {});

  // Throws InputError for a point outside the space or a non-finite y (use tell_failure instead).
  void tell(const Eigen::VectorXd& x, double y, bool fell = false);
  void tell_failure(const Eigen::VectorXd& x);
  // Several results at once (failed ones with failed = true), in order, with one model fit for all of
  // them: what a service does with the reports that arrived while its model was busy. Every point is
  // checked before any is recorded.
  void tell_batch(const std::vector<Observation>& batch);

  const std::vector<Observation>& observations() const { return observations_; }
  std::optional<Observation> best() const;  // lowest successful y
  struct Recommendation {
    std::size_t observation = 0;  // index into observations()
    double predicted = 0.0;       // posterior mean there in cost units (the observed y before the model is fitted)
  };
  // The successful observation with the lowest GP posterior mean (noise learned: a lucky draw is not
  // believed), or the lowest y while there is no model. Empty before the first success.
  std::optional<Recommendation> recommended() const;
  int num_successful() const;
  const HedgeState& hedge() const { return hedge_; }
  const SearchSpace& space() const { return space_; }
  const OptimizerOptions& options() const { return options_; }
  const GaussianProcess& model() const { return gp_; }
  const FallModel& fall_model() const { return fall_; }
  bool model_ready() const { return gp_.fitted() && !next_proposals_.empty(); }
  // Threads for the acquisition search (candidate posterior and local refinements, this one included).
  // Not part of the optimizer's state: what it proposes is the same, to the last bit, for any number.
  void set_threads(int threads) { threads_ = std::max(1, threads); }
  int threads() const { return threads_; }

  // Replays `observations` through tell(); the result proposes exactly what the original would, at the
  // price of one hyperparameter fit per observation after the initial design.
  static BayesianOptimizer rebuild(SearchSpace space, OptimizerOptions options,
                                   const std::vector<Observation>& observations);

  ModelState model_state() const;
  // The same optimizer as rebuild(), but from a saved ModelState of the first state.observations
  // observations: one factorisation with the saved hyperparameters instead of a fit per observation; the
  // observations after those (a state saved a little earlier) are told normally. Throws InputError when
  // the state does not fit the observations (more observations than given, wrong dimension).
  static BayesianOptimizer restore(SearchSpace space, OptimizerOptions options,
                                   const std::vector<Observation>& observations, const ModelState& state);

 private:
  struct Dataset {
    Eigen::MatrixXd X;  // unit cube
    Eigen::VectorXd y;
  };
  Dataset dataset() const;
  // What the GP models: dataset(), or past max_model_points its rows nearest the best (the local model).
  Dataset model_dataset() const;
  // The model's region for the data it models: the unit cube, or the local model's box.
  void set_region(const Dataset& model_data);
  void record(Observation obs);
  void refit();
  // Whether this refit re-optimises the hyperparameters (OptimizerOptions::hyperparameter_growth).
  bool hyperparameters_due() const;
  // Fits the fall model to the successful observations (fall_model on); optimise = false refactorises
  // with last_fall_hyper_.
  void fit_fall_model(bool optimise);
  // The end of a refit, once the GP is fitted: the next proposal of every acquisition.
  void propose(const Dataset& data);
  double to_model(double cost) const;     // the cost in the units the GP models (cost_transform)
  double from_model(double value) const;  // back to cost units
  void check_cost(double y, const char* where) const;  // throws InputError: not finite, or <= 0 under log
  bool model_due() const;  // enough observations for the model (the condition under which record() refits)
  std::mt19937_64 rng_for(std::uint64_t counter, std::uint64_t purpose) const;
  // The acquisition search's random candidates with their posterior on the current GP (in a fixed number
  // of column blocks: the same bits for any number of threads) and probability of not falling.
  struct Candidates {
    Eigen::MatrixXd C;  // d x m, unit cube
    std::vector<CandidatePosterior> blocks;
    Eigen::VectorXd p_safe;
    std::vector<bool> taken;  // chosen by best_candidate() in this ask
  };
  // m random points of the model's region (the unit cube, or the local model's box), with their posterior.
  Candidates draw_candidates(std::mt19937_64& rng, int m) const;
  // The untaken candidate where a draw from the current (lied-to) model's posterior marginals is lowest
  // (Thompson sampling, fall-weighted like LCB), marked taken.
  Eigen::VectorXd thompson_candidate(Candidates& c, std::mt19937_64& rng) const;
  // The posterior of c.C on the current GP, from scratch.
  void compute_posterior(Candidates& c) const;
  // After points were appended to the GP (append_fixed() returned true): the posterior's new rows only.
  void extend_posterior(Candidates& c) const;
  // Minimises each acquisition over the unit cube on the current GP. The random candidates and their
  // posterior are computed once and shared; each acquisition then refines its own best candidates.
  std::vector<Eigen::VectorXd> optimise_acquisitions(const std::vector<Acquisition>& acquisitions, double y_best,
                                                     std::mt19937_64& rng) const;
  std::vector<Eigen::VectorXd> refine_acquisitions(const std::vector<Acquisition>& acquisitions, double y_best,
                                                   const Candidates& candidates) const;
  std::vector<Eigen::VectorXd> ask_model(int n, const std::vector<Eigen::VectorXd>& pending, int issued);
  bool is_duplicate(const Eigen::VectorXd& u, const Eigen::MatrixXd& taken) const;
  bool constrained() const { return options_.constraints && !options_.constraints->empty(); }
  bool feasible_unit(const Eigen::VectorXd& u) const { return !constrained() || options_.constraints->feasible_unit(u); }
  // A uniform random point of the unit cube that satisfies the constraints (drawn until one does).
  Eigen::VectorXd random_unit_point(std::mt19937_64& rng) const;
  // The initial design: options_.initial_points rows, only feasible ones under constraints.
  Eigen::MatrixXd feasible_design() const;
  // The furthest feasible point on the segment from `inside` (feasible) towards `outside` (bisection).
  Eigen::VectorXd feasible_towards(const Eigen::VectorXd& inside, const Eigen::VectorXd& outside) const;

  SearchSpace space_;
  OptimizerOptions options_;
  Eigen::MatrixXd design_;  // initial design in the unit cube
  std::vector<Observation> observations_;
  GaussianProcess gp_;
  GpHyperparameters last_hyper_;
  bool have_hyper_ = false;
  int fits_ = 0;
  int fitted_observations_ = 0;  // observations the latest fit (or restore's factorisation) covered
  int optimised_observations_ = 0;  // observations at the latest hyperparameter optimisation
  HedgeState hedge_;
  FallModel fall_;
  GpHyperparameters last_fall_hyper_;
  bool have_fall_hyper_ = false;
  double fall_level_ = 0.0;  // mean model-unit cost of the observed falls
  std::vector<Eigen::VectorXd> next_proposals_;  // unit cube; per base acquisition (EI, LCB, PI) or one
  int threads_ = 1;
  Eigen::VectorXd region_lo_, region_hi_;  // unit cube; where the acquisition is searched (set_region)
};

}  // namespace cpgmatch::bo
