// The paper's figures from this project's data (gnuplot, PNG + SVG each; see gnuplot.hpp).
#pragma once

#include <filesystem>
#include <vector>

#include "cpgmatch/analysis/gnuplot.hpp"
#include "cpgmatch/analysis/replicates.hpp"
#include "cpgmatch/analysis/trial.hpp"

namespace cpgmatch::analysis {

using FigureFiles = std::vector<std::filesystem::path>;

// Fig. 5a (current minimum of the cost over rollouts, falls marked), Fig. 5b (every cost term per
// rollout) and Fig. 6 (normalised torque of non-fallen rollouts, sorted by cost, falls shaded), with
// fig6_cot beside it (their electrical cost of transport in the same order): fig5a/fig5b/fig6/fig6_cot
// .png/.svg in out_dir. Throws PlotError.
FigureFiles plot_study(const StudyTrials& study, const std::filesystem::path& out_dir);

// Fig. 4 from a rollout trace CSV (`cpgmatch rollout --trace`): the four legs' coupled phases, FL's hip
// and knee trajectories with stance shaded, and the four feedback activities of FL and FR as bands,
// over the last `window_s` seconds of the trace. fig4.png/.svg. Throws PlotError when gnuplot fails,
// plain std::runtime_error for a file that is not such a trace (no such file, columns missing).
FigureFiles plot_trace(const std::filesystem::path& trace_csv, const std::filesystem::path& out_dir,
                       double window_s = 4.0);

// Replicates: every seed's current-minimum curve with their mean (replicates_min_cost), and the
// J_feedback window means, mean ± sd over seeds as error bars (replicates_feedback). Throws PlotError.
FigureFiles plot_replicates(const std::vector<StudyTrials>& studies, const ReplicateSummary& summary,
                            const std::filesystem::path& out_dir);

// Best cost so far after each rollout (NaN until the first rollout that ran).
std::vector<double> current_minimum(const StudyTrials& study);

}  // namespace cpgmatch::analysis
