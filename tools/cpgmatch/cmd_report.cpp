// `cpgmatch report --store PATH [--study ID] --out DIR`: a stored study's figures and one self-contained
// report.html in DIR (study_report.hpp): the figures, the gait it found, the table beside the paper that
// `analyze` prints and the study's spec, readable offline.
#include <fmt/format.h>

#include "commands.hpp"
#include "cpgmatch/analysis/stored_study_trials.hpp"
#include "study_analysis.hpp"
#include "study_report.hpp"

namespace cpgmatch::cli {

namespace fs = std::filesystem;

void add_report_command(CLI::App& app) {
  struct Options {
    std::string store;
    int study = 0;
    std::string out;
    int jitter = 12;
    bool quiet = false;
  };
  auto opts = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand(
      "report", "a stored study's figures and one self-contained report.html (opens offline) in --out");
  cmd->add_option("--store", opts->store, "SQLite study store (e.g. results/paper-study-<time>/study.db)")->required();
  cmd->add_option("--study", opts->study, "study id (default: the last study in the store)");
  cmd->add_option("--out", opts->out, "output directory (created; its figures and report.html are replaced)")->required();
  cmd->add_option("--jitter", opts->jitter, "re-run the recommended parameters N times under +-1% jitter (0: skip)")
      ->capture_default_str();
  cmd->add_flag("--quiet", opts->quiet, "no progress on stderr");
  cmd->callback([opts] {
    if (opts->study < 0) throw InputError(fmt::format("--study {}: study ids are >= 1", opts->study));
    if (opts->jitter < 0) throw InputError(fmt::format("--jitter {}: must be >= 0", opts->jitter));
    const study::StoredStudy stored = analysis::load_stored_study(opts->store, opts->study);
    const fs::path out(opts->out);
    std::error_code error;
    fs::create_directories(out, error);
    if (error || !fs::is_directory(out)) {
      throw InputError(fmt::format("--out {}: cannot create that directory ({})", opts->out, error.message()));
    }
    const StudyAnalysis a = analyse_stored_study(stored, opts->jitter, opts->quiet);
    const analysis::FigureReport figures = write_study_figures(out, a, /*trace_best=*/true, opts->quiet);
    fmt::print("{}\n", write_study_report(out, a, stored, figures).string());
  });
}

}  // namespace cpgmatch::cli
