// The study's answer: the evaluated parameters the model believes best, not the luckiest single rollout.
//
// With sensor noise and per-trial seeds a rollout's cost is one noisy draw. The lowest observed cost is
// therefore biased low (a winner's curse) and can belong to a point whose neighbours fall. Like
// scikit-optimize's `expected_minimum`, but restricted to points that were actually run (a recommendation
// a user can check against its own rollout), the answer is the trial with the lowest GP posterior mean:
// a Matérn 5/2 GP with a learned noise term, fitted to every rollout that ran (falls included, with the
// cost the optimizer saw) in the search space's unit cube.
#pragma once

#include <map>
#include <optional>
#include <string>

#include "cpgmatch/analysis/trial.hpp"

namespace cpgmatch::analysis {

struct Recommendation {
  int rollout = 0;              // 1-based, as in the report
  double predicted_cost = 0.0;  // GP posterior mean at that point
  double predicted_sd = 0.0;    // GP posterior sd of the latent cost there
  double observed_cost = 0.0;   // what its own rollout cost
  bool fell = false;
  std::map<std::string, double> params;
};

// Empty when fewer than two rollouts ran or the study has no search bounds. Deterministic.
std::optional<Recommendation> recommend(const StudyTrials& study);

}  // namespace cpgmatch::analysis
