// How robust is the best point? Its cost again under small parameter perturbations: a best cost that
// was a lucky spike of a noisy or chaotic landscape shows up as a much higher mean or many falls here.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "cpgmatch/analysis/trial.hpp"

namespace cpgmatch::analysis {

struct RolloutOutcome {
  bool ok = false;    // the rollout ran
  bool fell = false;
  double cost = 0.0;
};

// Runs one rollout of these parameters (every parameter, fixed ones included) with this rollout seed.
using RolloutEvaluator = std::function<RolloutOutcome(const std::map<std::string, double>& params, std::uint64_t seed)>;

struct JitterOptions {
  int draws = 12;
  double relative = 0.01;         // each optimised parameter times 1 + U(-relative, relative)
  std::uint64_t jitter_seed = 1;  // the perturbations' random generator
  std::uint64_t rollout_seed = 0; // draw k runs with derived_seed(rollout_seed, 1000000 + k): trial ids stay below
};

struct JitterSummary {
  int draws = 0;
  int failed = 0;  // evaluations that did not run
  int falls = 0;
  double relative = 0.0;
  double cost_mean = 0.0;  // over rollouts that ran, falls included
  double cost_sd = 0.0;
  std::vector<double> costs;
};

// Perturbs the optimised parameters (those in `bounds`), clamps them to their search range, leaves
// the fixed ones alone. Deterministic for a given jitter_seed.
std::vector<std::map<std::string, double>> jittered_points(const std::map<std::string, double>& params,
                                                           const std::map<std::string, Bounds>& bounds,
                                                           const JitterOptions& options);
JitterSummary jitter_best(const std::map<std::string, double>& params, const std::map<std::string, Bounds>& bounds,
                          const RolloutEvaluator& evaluate, const JitterOptions& options = {});

}  // namespace cpgmatch::analysis
