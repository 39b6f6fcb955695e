// `cpgmatch export --store PATH [--study ID] --format csv|optuna-journal|json [--out FILE]`: a stored study's
// trials for the tools a lab already uses: pandas or a spreadsheet (csv), Optuna's dashboard and plots
// (optuna-journal), anything else (json). One row per trial; docs/analysis.md lists the columns.
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>

#include <fmt/format.h>

#include "commands.hpp"
#include "cpgmatch/analysis/optuna_journal.hpp"
#include "cpgmatch/analysis/stored_study_trials.hpp"
#include "cpgmatch/analysis/study_export.hpp"

namespace cpgmatch::cli {

namespace fs = std::filesystem;

namespace {

std::vector<analysis::ExportedStudy> exported_studies(const std::string& store_path, int study_id) {
  std::vector<study::StoredStudy> stored;
  if (study_id > 0) {
    stored.push_back(analysis::load_stored_study(store_path, study_id));
  } else {
    if (!fs::exists(store_path)) throw InputError(fmt::format("--store '{}': no such study store", store_path));
    stored = study::StudyStore(store_path, study::kReadOnly).load_all();
    analysis::require_every_trial_readable(stored, store_path);
  }
  std::vector<analysis::ExportedStudy> out;
  for (const auto& s : stored) out.push_back(analysis::export_study(s));
  return out;
}

}  // namespace

void add_export_command(CLI::App& app) {
  struct Options {
    std::string store;
    int study = 0;
    std::string format;
    std::string out;
  };
  auto opts = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand("export", "a stored study's trials as CSV, JSON or an Optuna journal (one row per trial)");
  cmd->add_option("--store", opts->store, "SQLite study store")->required();
  cmd->add_option("--study", opts->study, "study id (default: every study in the store)");
  cmd->add_option("--format", opts->format,
                  "csv (pandas, spreadsheets), optuna-journal (optuna.storages.JournalFileStorage), json")
      ->required()
      ->check(CLI::IsMember({"csv", "optuna-journal", "json"}));
  cmd->add_option("--out", opts->out, "output file (default: standard output)");
  cmd->callback([opts] {
    if (opts->study < 0) throw InputError(fmt::format("--study {}: study ids are >= 1", opts->study));
    const auto studies = exported_studies(opts->store, opts->study);
    std::ostringstream text;
    std::vector<std::string> names;
    if (opts->format == "csv") {
      analysis::write_csv(studies, text);
    } else if (opts->format == "json") {
      text << analysis::export_json(studies).dump(2) << '\n';
    } else {
      names = analysis::write_optuna_journal(studies, text);
    }
    std::size_t trials = 0;
    for (const auto& s : studies) trials += s.trials.size();
    if (opts->out.empty()) {
      std::cout << text.str() << std::flush;
    } else {
      std::ofstream out(opts->out, std::ios::binary | std::ios::trunc);
      if (!out) throw InputError(fmt::format("--out '{}': cannot write the file", opts->out));
      out << text.str();
      out.close();
      if (!out) throw std::runtime_error(fmt::format("--out '{}': writing failed", opts->out));
    }
    fmt::print(stderr, "exported {} trial(s) of {} study(ies) as {}{}\n", trials, studies.size(), opts->format,
               opts->out.empty() ? "" : " to " + opts->out);
    for (std::size_t i = 0; i < names.size(); ++i) {
      fmt::print(stderr, "  study {} -> Optuna study '{}'\n", studies[i].study_id, names[i]);
    }
  });
}

}  // namespace cpgmatch::cli
