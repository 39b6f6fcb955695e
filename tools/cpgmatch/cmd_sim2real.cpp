// `cpgmatch sim2real --store PATH [--study ID] [--json] [--plot DIR]`: simulation versus hardware for a
// stored study, per cost term and total (the paper's Supplementary Table 3; services/analysis/sim2real).
#include <iostream>

#include <fmt/format.h>

#include "commands.hpp"
#include "cpgmatch/analysis/sim2real.hpp"
#include "cpgmatch/analysis/stored_study_trials.hpp"

namespace cpgmatch::cli {

void add_sim2real_command(CLI::App& app) {
  struct Options {
    std::string store;
    int study = 0;
    bool json = false;
    std::string plot_dir;
  };
  auto opts = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand("sim2real", "cost terms on simulation vs hardware workers (Supplementary Table 3)");
  cmd->add_option("--store", opts->store, "SQLite study store")->required();
  cmd->add_option("--study", opts->study, "study id (default: the last study in the store)");
  cmd->add_flag("--json", opts->json, "print the table as one JSON object");
  cmd->add_option("--plot", opts->plot_dir, "also draw sim2real.png/.svg into this folder");
  cmd->callback([opts] {
    if (opts->study < 0) throw InputError(fmt::format("--study {}: study ids are >= 1", opts->study));
    const auto trials = analysis::trials_from_stored_study(analysis::load_stored_study(opts->store, opts->study));
    const auto table = analysis::sim2real_table(trials);
    if (!opts->plot_dir.empty()) analysis::plot_sim2real(trials, opts->plot_dir);
    if (opts->json) {
      std::cout << analysis::sim2real_json(table).dump() << std::endl;
    } else {
      fmt::print("{}", analysis::sim2real_text(table));
    }
  });
}

}  // namespace cpgmatch::cli
