// `cpgmatch study run`: a full local study (the paper's, by default) through the service (see
// local_study.hpp), then its science report beside the paper's numbers, analysis.json and the figures
// in its results folder (study_results.hpp).
#include <iostream>

#include <fmt/format.h>

#include "commands.hpp"
#include "cpgmatch/analysis/science_report.hpp"
#include "local_study.hpp"
#include "study_results.hpp"

namespace cpgmatch::cli {

void add_study_command(CLI::App& app) {
  CLI::App* study = app.add_subcommand("study", "run and manage optimisation studies");
  study->require_subcommand(1);
  add_study_service_commands(study);
  add_spec_commands(app, study);
  struct Options {
    LocalStudyFlags common;
    std::string store;
    int domain = -1;
    bool json = false;
  };
  auto opts = std::make_shared<Options>();
  CLI::App* run = study->add_subcommand(
      "run", "run a study locally to completion: optimizer service and workers as child processes on a private DDS domain");
  opts->common.add_to(*run, "results directory (default: results/<name>-<time>)");
  run->add_option("--store", opts->store, "SQLite study store (default: <out>/study.db)");
  run->add_option("--domain", opts->domain, "DDS domain id (default: a private one, 150..229)");
  run->add_flag("--json", opts->json, "print the science report as one JSON object");
  run->callback([opts] {
    LocalStudyOptions o = opts->common.options();
    o.store = opts->store;
    o.domain = opts->domain;
    const LocalStudyResult result = run_local_study(o);
    const StudyAnalysis a = write_study_results(result, opts->common.jitter, o.quiet);
    if (opts->json) {
      std::cout << a.json.dump() << std::endl;
      return;
    }
    fmt::print("\nstudy '{}': {} rollouts in {:.1f} s ({:.2f} rollouts/s)\n", result.config.name, a.report.rollouts,
               result.wall_time_s, a.report.rollouts / result.wall_time_s);
    fmt::print("{}{}", analysis::format_table(a.report), a.sim2real_text);
    fmt::print("results: {}  (report.html, analysis.json, fig4/fig5a/fig5b/fig6/fig6_cot/param_slices/param_importance/param_parallel .png/.svg, trials.jsonl, best_params.yaml, study.db)\n",
               result.dir.string());
  });
}

}  // namespace cpgmatch::cli
