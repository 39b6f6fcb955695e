// `cpgmatch store check --store PATH`: is the whole store readable? SQLite's integrity_check over every page,
// then every study's stored text, every trial row and every kept trace read as the readers read them. Exit 0
// when all is, 1 with each problem named when not; the store is opened read-only.
#include <filesystem>

#include <fmt/format.h>

#include "commands.hpp"
#include "cpgmatch/analysis/stored_study_trials.hpp"
#include "cpgmatch/errors.hpp"
#include "cpgmatch/study/study_store.hpp"

namespace cpgmatch::cli {

void add_store_command(CLI::App& app) {
  CLI::App* store = app.add_subcommand("store", "check a study store");
  store->require_subcommand(1);
  auto path = std::make_shared<std::string>();
  CLI::App* check = store->add_subcommand(
      "check", "SQLite integrity_check, then every study text, trial and trace read back; exit 1 naming each problem");
  check->add_option("--store", *path, "SQLite study store")->required();
  check->callback([path] {
    if (!std::filesystem::exists(*path)) throw InputError(fmt::format("--store '{}': no such study store", *path));
    const study::StudyStore s(*path, study::kReadOnly);  // refuses what is not a cpgmatch store
    std::vector<std::string> problems;
    if (const std::string integrity = s.integrity_check(); integrity != "ok") problems.push_back("SQLite: " + integrity);
    std::size_t trials = 0, traces = 0;
    const auto studies = s.load_all();
    for (const auto& st : studies) {
      try {
        (void)analysis::stored_study_config(st);
      } catch (const std::exception& e) {
        problems.push_back(e.what());
      }
      for (const auto& why : st.unreadable_trials) problems.push_back(fmt::format("study {} {}", st.study_id, why));
      trials += st.trials.size();
      try {
        traces += s.load_traces(st.study_id).size();
      } catch (const std::exception& e) {
        problems.push_back(fmt::format("study {}: {}", st.study_id, e.what()));
      }
    }
    if (!problems.empty()) {
      std::string list;
      for (const auto& p : problems) list += "\n  " + p;
      throw std::runtime_error(fmt::format("study store {}: {} problem(s):{}", *path, problems.size(), list));
    }
    fmt::print("study store {}: ok ({} studies, {} trials, {} traces readable; schema version {})\n", *path,
               studies.size(), trials, traces, study::kStoreSchemaVersion);
  });
}

}  // namespace cpgmatch::cli
