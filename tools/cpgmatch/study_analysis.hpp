// The command line's glue between a finished study and the analysis library: in-process rollouts for
// the jitter test and Fig. 4, and the files a study's results folder gets (analysis.json, figures).
#pragma once

#include <filesystem>
#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "cpgmatch/analysis/jitter.hpp"
#include "cpgmatch/analysis/plots.hpp"
#include "cpgmatch/analysis/science_report.hpp"
#include "cpgmatch/analysis/trial.hpp"
#include "cpgmatch/study/study_config.hpp"
#include "cpgmatch/study/study_spec.hpp"
#include "cpgmatch/study/study_store.hpp"

namespace cpgmatch::cli {

// Runs rollouts in this process (the `sim` library) under the study's conditions: its spec's model,
// settings and base parameters, its terrain and timing, as the sim worker does.
analysis::RolloutEvaluator sim_evaluator(std::shared_ptr<const study::StudySpec> spec);
// A stored study's spec: the stored one, or (a store from before specs not yet opened by an optimizer)
// the one this release's migration gives it.
std::shared_ptr<const study::StudySpec> stored_spec(const study::StoredStudy& stored);

struct StudyAnalysis {
  std::shared_ptr<const study::StudySpec> spec;
  study::StudyConfig config;
  analysis::StudyTrials trials;
  analysis::ScienceReport report;
  nlohmann::json json;  // to_json(report), with "sim2real" when hardware rollouts exist
  // The simulation-versus-hardware section of the report (empty without hardware rollouts).
  std::string sim2real_text;
  bool has_hardware = false;
  analysis::StudyTrials all_trials;  // with the hardware rollouts (set only when there are some)
};

// The science report of a stored study; with jitter_draws > 0 the best point is re-run that many
// times under ±1% jitter (progress on stderr unless quiet).
StudyAnalysis analyse_stored_study(const study::StoredStudy& stored, int jitter_draws, bool quiet);

// On stderr: what a set of figures could not draw ("not drawn: ...") and gnuplot's failures.
void print_figure_report(const analysis::FigureReport& report);

// fig5a/fig5b/fig6 and the parameter figures into dir; with `trace_best`, also one traced rollout of the best parameters
// (best_trace.csv) and fig4 from it. Figure failures are reported on stderr and in the returned report's `failed`
// (the study's numbers are still good without them); what the data could not give is in its `not_drawn`.
analysis::FigureReport write_study_figures(const std::filesystem::path& dir, const StudyAnalysis& a, bool trace_best,
                                           bool quiet);

}  // namespace cpgmatch::cli
