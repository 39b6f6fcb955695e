// The paper's figures from this project's data (gnuplot, PNG + SVG each; see gnuplot.hpp).
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "cpgmatch/analysis/gnuplot.hpp"
#include "cpgmatch/analysis/replicates.hpp"
#include "cpgmatch/analysis/trial.hpp"

namespace cpgmatch::analysis {

using FigureFiles = std::vector<std::filesystem::path>;

// What drawing a set of figures came to. A study's data decides what can be drawn (no rollout that
// walked, no positive torque for a log axis, no model yet): such a figure, or the part of it, is left out
// and said in `not_drawn`, and the rest is drawn. `failed` is gnuplot failing on a script (a bug, not the
// data): that figure is missing, the others are still drawn.
struct FigureReport {
  FigureFiles files;
  std::vector<std::string> not_drawn;  // "fig6: ...", in plain words
  std::vector<std::string> failed;     // PlotError messages (they name the script)
};

// A figure as a gnuplot body, or the reason it cannot be drawn from this data (`unavailable`), with notes
// on what it leaves out.
struct FigureScript {
  explicit FigureScript(std::string stem_name) : stem(std::move(stem_name)) {}
  std::string stem;
  std::string body;
  int width_px = 1000;
  int height_px = 600;
  std::string unavailable;          // non-empty: not drawn, and why
  std::vector<std::string> notes;   // drawn, but without these
};
// Renders the script into `report` (files, or the reason, or gnuplot's failure).
void draw_figure(const std::filesystem::path& dir, const FigureScript& figure, FigureReport& report);

// Fig. 5a (cost per rollout and its current minimum; falls in a band of their own above, so that their
// cost does not flatten the walking costs), Fig. 5b (every cost term per rollout, log scale; falls in a strip
// above it, terms below the log axis' floor in a strip below it), Fig. 6 (normalised torque of the rollouts
// that walked, sorted by cost, falls shaded), fig6_cot beside it (their electrical cost of transport in the
// same order), and the parameter figures (parameter_plots): fig5a, fig5b, fig6, fig6_cot, param_slices, param_importance, param_parallel (.png/.svg) in out_dir. Never throws for what the
// data lacks; throws PlotError only when gnuplot is not installed.
FigureReport plot_study(const StudyTrials& study, const std::filesystem::path& out_dir);

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
