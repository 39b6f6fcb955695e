// `cpgmatch study run`: a full local study (the paper's, by default) through the service (see
// local_study.hpp), then its science report beside the paper's numbers, analysis.json and the figures
// in its results folder (study_results.hpp). `cpgmatch study extend` and `study enqueue`: steering a study
// on a service as Optuna users do (docs/steering.md).
#include <iostream>

#include <fmt/format.h>

#include "commands.hpp"
#include "flag_checks.hpp"
#include "cpgmatch/analysis/science_report.hpp"
#include "gait_files.hpp"
#include "local_study.hpp"
#include "service_flags.hpp"
#include "study_client.hpp"
#include "study_results.hpp"

namespace cpgmatch::cli {

namespace {

void add_steering_commands(CLI::App* study) {
  {
    struct Options {
      ServiceFlags service;
      int study_id = 0;
      int added = 0;
    };
    auto o = std::make_shared<Options>();
    CLI::App* cmd = study->add_subcommand(
        "extend",
        "continue a stopped or finished study with N more trials (its model, exactly as a restart continues it)");
    cmd->add_option("id", o->study_id, "study id")->required()->check(study_id());
    cmd->add_option("--budget", o->added,
                    "trials to ADD to the study's budget, as Optuna's n_trials in study.optimize() (a study of 30 "
                    "extended with --budget 20 ends at 50)")
        ->required();
    add_service_flags(cmd, o->service, "operator");
    cmd->callback([o] {
      if (o->added <= 0) throw InputError(fmt::format("--budget: the trials to add must be > 0, got {}", o->added));
      runtime::apply_dds_flags(o->service.dds);
      client::StudyClient c(o->service.resolved_domain(), o->service.localhost_only, false, /*read_workers=*/false);
      const client::CommandResult r = c.extend(o->study_id, o->added, o->service.timeout_s);
      if (!r.ok) throw InputError(r.message);  // unknown study, a failed one, ...
      fmt::print("{}\n", r.message);
    });
  }
  {
    struct Options {
      ServiceFlags service;
      int study_id = 0;
      std::vector<std::string> params;
    };
    auto o = std::make_shared<Options>();
    CLI::App* cmd = study->add_subcommand(
        "enqueue", "run known gaits as a study's next trials (Optuna's enqueue_trial); they count in its budget");
    cmd->add_option("id", o->study_id, "study id (running, paused or stopped)")->required()->check(study_id());
    cmd->add_option("--params", o->params,
                    "a parameter file (like configs/params/default.yaml); repeat for several gaits, queued in order")
        ->required();
    add_service_flags(cmd, o->service, "operator");
    cmd->callback([o] {
      constexpr std::size_t kMaxGaits = 64;  // StudyCommand.enqueue's bound on the wire
      if (o->params.size() > kMaxGaits) {
        throw InputError(fmt::format("--params: {} files, at most {} gaits per command", o->params.size(), kMaxGaits));
      }
      std::vector<domain::EnqueuedGait> gaits;
      for (const auto& file : o->params) gaits.push_back(read_gait_file(file, file));
      runtime::apply_dds_flags(o->service.dds);
      client::StudyClient c(o->service.resolved_domain(), o->service.localhost_only, false, /*read_workers=*/false);
      const client::CommandResult r = c.enqueue(o->study_id, gaits, o->service.timeout_s);
      if (!r.ok) throw InputError(r.message);  // a gait outside the space or a constraint, no room, ...
      fmt::print("{}\n", r.message);
    });
  }
}

}  // namespace

void add_study_command(CLI::App& app) {
  CLI::App* study = app.add_subcommand("study", "run and manage optimisation studies");
  study->require_subcommand(1);
  add_study_service_commands(study);
  add_steering_commands(study);
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
