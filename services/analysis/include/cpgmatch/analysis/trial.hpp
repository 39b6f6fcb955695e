// A study as the analysis sees it: its rollouts in trial order, each with the report's numbers, plus
// the search space's bounds (for the jitter test). Built from the SQLite store by
// cpgmatch_analysis_store, or by hand in tests.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "cpgmatch/cost.hpp"
#include "cpgmatch/energy.hpp"

namespace cpgmatch::analysis {

// The cost terms (eqs. 2-7) are the science's own type: the analysis reads what the rollout computed.
using cpgmatch::CostTerms;

struct Trial {
  int trial_id = 0;                // 0-based, the store's order; "rollout k" in the report is trial_id + 1
  bool ok = false;                 // the rollout ran (a fall is ok); false: the evaluation failed
  bool fell = false;
  double cost = 0.0;
  CostTerms terms;
  double normalized_torque = 0.0;  // eq. 1, N m / (m/s)
  double summed_torque_nm = 0.0;   // eq. 1's numerator, N m
  double mean_speed_mps = 0.0;
  double distance_m = 0.0;
  EnergyMeasures energy;           // what the motors spent (energy.hpp); NaN in stores from before energy
  std::map<std::string, double> params;  // every parameter of the rollout (optimised and fixed)
  bool hardware = false;           // run by a hardware worker (the report's worker_kind)
  // No gait was simulated: a service benchmark's synthetic cost (the report's `synthetic`). Never in a
  // figure or the science report (exploration_trials leaves it out and counts it).
  bool synthetic = false;
  std::string outcome;             // the report's outcome (completed, fell, error, refused, ...); empty: an older store

  bool walked() const { return ok && !fell; }
};

struct Bounds {
  double low = 0.0;
  double high = 0.0;
};

// A dimension of the search space as the optimizer sees it (its model works in the unit cube of these).
struct SearchDimension {
  std::string name;
  double low = 0.0;
  double high = 1.0;
  bool log_scale = false;
  std::string unit;  // SI, as the study's search space says ("rad", "Hz"); "1" or empty: dimensionless
};

struct StudyTrials {
  std::string name;
  int study_id = 0;
  int initial_points = 15;         // the random initial design
  std::uint64_t seed = 0;          // the study's seed (its rollouts' seed too)
  std::map<std::string, Bounds> bounds;  // the optimised parameters and their search ranges
  std::vector<Trial> trials;       // ordered by trial_id
  // Synthetic rollouts (Trial::synthetic) that exploration_trials took out of `trials`: figures and the
  // science report say how many they left out.
  int synthetic_left_out = 0;
  // The optimizer's view, for the figures of its model (surrogate.hpp). Empty dimensions: the `bounds`,
  // linear, in name order (a hand-made study).
  std::vector<SearchDimension> dimensions;  // in the optimizer's order (its model's inputs)
  bool log_cost = false;                    // the optimizer modelled log(cost) (cost_transform: log)
  // GpHyperparameters::pack() of the optimizer's latest fit, as saved in the store ([log amplitude, log length
  // scales in `dimensions` order, log noise]), and how many observations that fit saw; empty: none saved.
  std::vector<double> model_hyperparameters;
  int model_observations = 0;
};

// The trial's optimised parameters scaled to [0, 1] by their search ranges, in `bounds` order (the GP's
// input). A parameter the trial lacks counts as its lower bound; a range of zero width maps to 0.5.
std::vector<double> unit_point(const Trial& t, const std::map<std::string, Bounds>& bounds);

// One rollout report (domain::to_json(RolloutReport)) as a Trial. Old stores have no
// `summed_torque_nm` (or null): it is rebuilt as normalized_torque x mean_speed_mps; nor `energy`: NaN.
Trial trial_from_report(int trial_id, const nlohmann::json& report, std::map<std::string, double> params);

}  // namespace cpgmatch::analysis
