// What the optimizer's model (its Gaussian process) says about a study's parameters, for the figures
// users of Optuna and scikit-optimize expect: parameter importance and partial dependence.
//
// Importance comes from the GP's ARD length scales: the Matérn kernel divides each parameter's distance by
// its own length scale l_d (in the unit cube of the search space), so the cost changes over 1/l_d of a
// range's width; relevance_d = (1/l_d) / sum_k (1/l_k). A parameter whose length scale sits at the upper
// bound (100 ranges) does not matter to the model at all. It is the model's belief, not a variance
// decomposition (Optuna's fANOVA): a parameter never varied, or one whose effect the noise hides, scores low.
//
// The GP is the optimizer's own where the store saved it: its hyperparameters, its inputs (the search
// space's unit cube, log dimensions in log), its cost units (log(cost) under cost_transform: log) and its
// data (every exploration rollout that ran, a failed one at the worst cost seen, one that said nothing about
// its point left out). Without a saved state (an older store) the hyperparameters are fitted here.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "cpgmatch/analysis/trial.hpp"

namespace cpgmatch::analysis {

struct ParameterImportance {
  std::string name;
  double length_scale = 0.0;  // in units of the parameter's search range (unit cube)
  double relevance = 0.0;     // (1/l) normalised over the parameters: they sum to 1
};

// Friedman's partial dependence: the model's mean cost with one parameter set to x, averaged over the
// other parameters of every rollout that ran (what skopt.plots.plot_objective draws on its diagonal).
struct PartialDependence {
  std::string name;
  std::vector<double> x;     // the parameter's values, in its own units, low to high
  std::vector<double> cost;  // cost units (under a log model: exp of the averaged log cost, a geometric mean)
};

struct SurrogateView {
  std::string source;  // in words: the optimizer's saved model of N rollouts, or hyperparameters fitted here
  int rollouts = 0;    // the data the GP was conditioned on
  std::vector<ParameterImportance> importance;          // search-space order
  std::vector<PartialDependence> partial_dependence;    // search-space order
};

// Empty (with the reason in *why) when fewer than 3 rollouts ran or the study has no search space.
// Deterministic: the same study gives the same view.
std::optional<SurrogateView> surrogate_view(const StudyTrials& study, std::string* why, int grid_points = 41);

// The study's search dimensions in the optimizer's order (StudyTrials::dimensions, else its bounds).
std::vector<SearchDimension> search_dimensions(const StudyTrials& study);

}  // namespace cpgmatch::analysis
