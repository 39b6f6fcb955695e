// A study: which parameters to optimise, the budget and the rollout conditions. Every key but `name`
// defaults to the paper's value (150 rollouts, 15 random, gp_hedge, six parameters, 10 s + 10 s).
//
//   name: my-study
//   budget: 150
//   initial_points: 15
//   acquisition: gp_hedge
//   seed: 0
//   rollout: {entrain_s: 10, eval_s: 10}
//   terrain: flat
//   parameters: [{name: hip_offset, low: -0.35, high: 0.35}, ...]   # the paper's six when omitted
//   fixed: {frequency: 1.0, knee_amplitude: 0.5236}
#pragma once

#include <string>

#include "cpgmatch/bo/optimizer.hpp"
#include "cpgmatch/bo/search_space.hpp"

namespace cpgmatch::cli {

struct StudyConfig {
  std::string name = "paper-study";
  int budget = 150;
  bo::OptimizerOptions optimizer;
  bo::SearchSpace space = bo::SearchSpace::paper_cpg_space();
  double entrain_s = 10.0;
  double eval_s = 10.0;
  std::string terrain = "flat";
};

// Throws InputError naming the file, line and field.
StudyConfig load_study_config(const std::string& path);

}  // namespace cpgmatch::cli
