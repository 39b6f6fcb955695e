// `cpgmatch plot --store PATH [--study ID] [--out DIR]`: Fig. 5a, 5b and 6 of a stored study and its
// parameter figures (slices with the GP's partial dependence, importance, parallel coordinates); what the
// study's data cannot give is said on stderr and the rest drawn (exit 0);
// `cpgmatch plot --trace FILE.csv [--out DIR]`: Fig. 4 from a rollout trace (`cpgmatch rollout --trace`).
#include <filesystem>

#include <fmt/format.h>

#include "commands.hpp"
#include "study_analysis.hpp"
#include "cpgmatch/analysis/plots.hpp"
#include "cpgmatch/analysis/sim2real.hpp"
#include "cpgmatch/analysis/stored_study_trials.hpp"

namespace cpgmatch::cli {

namespace fs = std::filesystem;

void add_plot_command(CLI::App& app) {
  struct Options {
    std::string store;
    int study = 0;
    std::string trace;
    std::string out;
    double window_s = 4.0;
  };
  auto opts = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand("plot", "the paper's figures and the parameter figures (PNG and SVG) from a stored study, or Fig. 4 from a rollout trace");
  cmd->add_option("--store", opts->store, "SQLite study store: Fig. 5a, 5b, 6, param_slices, param_importance, param_parallel");
  cmd->add_option("--study", opts->study, "study id (default: the last study in the store)");
  cmd->add_option("--trace", opts->trace, "rollout trace CSV (cpgmatch rollout --trace F.csv): Fig. 4");
  cmd->add_option("--window", opts->window_s, "Fig. 4: the last this many seconds of the trace");
  cmd->add_option("--out", opts->out, "output directory (default: the store's or the trace's directory)");
  cmd->callback([opts] {
    if (opts->store.empty() == opts->trace.empty()) throw InputError("give exactly one of --store and --trace");
    if (opts->study < 0) throw InputError(fmt::format("--study {}: study ids are >= 1", opts->study));
    if (!(opts->window_s > 0.0)) throw InputError("--window must be > 0 seconds");
    analysis::FigureFiles files;
    if (!opts->store.empty()) {
      const auto stored = analysis::load_stored_study(opts->store, opts->study);
      const fs::path out = opts->out.empty() ? fs::absolute(opts->store).parent_path() : fs::path(opts->out);
      // A mixed study's hardware validation sets are not the optimizer's history (sim2real draws them).
      const analysis::FigureReport report =
          analysis::plot_study(analysis::exploration_trials(analysis::trials_from_stored_study(stored)), out);
      for (const auto& f : report.files) fmt::print("{}\n", f.string());
      print_figure_report(report);
      // What the data cannot give is not a failure; gnuplot failing on a script is.
      if (!report.failed.empty()) throw std::runtime_error(fmt::format("{} figure(s) failed", report.failed.size()));
      return;
    } else {
      if (!fs::is_regular_file(opts->trace)) throw InputError(fmt::format("--trace '{}': no such file", opts->trace));
      const fs::path out = opts->out.empty() ? fs::absolute(opts->trace).parent_path() : fs::path(opts->out);
      try {
        files = analysis::plot_trace(opts->trace, out, opts->window_s);
      } catch (const analysis::PlotError&) {
        throw;
      } catch (const std::runtime_error& e) {
        throw InputError(fmt::format("--trace: {}", e.what()));  // the file is not a usable trace
      }
    }
    for (const auto& f : files) fmt::print("{}\n", f.string());
  });
}

}  // namespace cpgmatch::cli
