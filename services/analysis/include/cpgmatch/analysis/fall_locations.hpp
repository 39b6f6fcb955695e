// Where in the search space the falls after the initial design happened: next to the best gait found so
// far (the search refining at the edge of what walks), or at the corners of the space (the acquisition
// function exploring where the model knows least). The two call for different remedies, and the falls
// count alone cannot tell them apart.
//
// Distances are measured in the unit cube of the optimised parameters (each scaled by its search range),
// so a parameter with a wide range does not dominate.
#pragma once

#include "cpgmatch/analysis/trial.hpp"

namespace cpgmatch::analysis {

struct FallLocationOptions {
  double bound_margin = 0.02;  // a parameter within this fraction of its range from a bound is "at" it
  double near_best = 0.15;     // unit-cube distance within which a rollout is "next to" the best so far
};

// Medians over the rollouts after the initial design that ran, split into falls and the others (walked).
struct FallLocations {
  int falls = 0;
  int walked = 0;
  double falls_params_at_bound_median = 0.0;   // how many optimised parameters sit at a bound
  double walked_params_at_bound_median = 0.0;
  double falls_distance_to_best_median = 0.0;  // unit-cube distance to the lowest-cost rollout before it
  double walked_distance_to_best_median = 0.0;
  int falls_near_best = 0;                     // falls within near_best of the best so far
};

// NaN medians for an empty group. Needs the study's bounds; parameters without bounds (fixed ones) are
// ignored, a bounded one a trial lacks counts as its lower bound (unit_point()). The best so far is the
// lowest finite cost among the rollouts that ran before.
FallLocations fall_locations(const StudyTrials& study, const FallLocationOptions& options = {});

}  // namespace cpgmatch::analysis
