// `cpgmatch analyze --store PATH [--study ID] [--json] [--jitter N]`: the science report of a stored
// study beside the paper's numbers (services/analysis; docs/analysis.md explains each statistic).
#include <iostream>

#include <fmt/format.h>

#include "commands.hpp"
#include "cpgmatch/analysis/stored_study_trials.hpp"
#include "study_analysis.hpp"

namespace cpgmatch::cli {

void add_analyze_command(CLI::App& app) {
  struct Options {
    std::string store;
    int study = 0;
    bool json = false;
    int jitter = 12;
    bool quiet = false;
  };
  auto opts = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand("analyze", "the science report of a finished study, beside the paper's numbers");
  cmd->add_option("--store", opts->store, "SQLite study store (e.g. results/paper-study-<time>/study.db)")->required();
  cmd->add_option("--study", opts->study, "study id (default: the last study in the store)");
  cmd->add_flag("--json", opts->json, "print the report as one JSON object");
  cmd->add_option("--jitter", opts->jitter, "re-run the best parameters N times under +-1% jitter (0: skip)");
  cmd->add_flag("--quiet", opts->quiet, "no progress of the jitter rollouts on stderr");
  cmd->callback([opts] {
    if (opts->study < 0) throw InputError(fmt::format("--study {}: study ids are >= 1", opts->study));
    if (opts->jitter < 0) throw InputError(fmt::format("--jitter {}: must be >= 0", opts->jitter));
    const auto stored = analysis::load_stored_study(opts->store, opts->study);
    const StudyAnalysis a = analyse_stored_study(stored, opts->jitter, opts->quiet || opts->json);
    if (opts->json) {
      std::cout << a.json.dump() << std::endl;
    } else {
      fmt::print("{}{}", analysis::format_table(a.report), a.sim2real_text);
    }
  });
}

}  // namespace cpgmatch::cli
