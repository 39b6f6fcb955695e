// The parameter figures users of Optuna and scikit-optimize look for, drawn with gnuplot from a study:
//   param_slices      cost of every rollout against each parameter (Optuna's plot_slice), with the GP's
//                     partial dependence over it (the diagonal of skopt's plot_objective);
//   param_importance  how much each parameter matters to the GP (its length scales; surrogate.hpp);
//   param_parallel    parallel coordinates: every rollout as a line through its parameters to its cost.
// Falls cost 13-19 where a walking gait costs 0.4-6: they are drawn in a band of their own, not to scale.
#pragma once

#include <filesystem>
#include <vector>

#include "cpgmatch/analysis/plots.hpp"
#include "cpgmatch/analysis/trial.hpp"

namespace cpgmatch::analysis {

// The three figures' scripts (their data files are written into dir); each says when it cannot be drawn.
std::vector<FigureScript> parameter_figures(const StudyTrials& study, const std::filesystem::path& dir);

}  // namespace cpgmatch::analysis
