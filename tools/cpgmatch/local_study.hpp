// One study run locally to completion through the service: the optimizer service and simulation
// workers as child processes on a private DDS domain (UDP on loopback only), the study submitted, a
// progress bar until it is done, the children stopped. Shared by `study run` and `reproduce`.
#pragma once

#include <filesystem>
#include <optional>
#include <string>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "cpgmatch/study/study_config.hpp"

namespace cpgmatch::cli {

struct LocalStudyOptions {
  std::string config_text;    // the study file's text
  std::string config_source;  // its name in messages
  int workers = 0;            // 0: one per core
  std::filesystem::path out;  // results directory; empty: results/<name>-<time>
  std::string store;          // empty: <out>/study.db
  int domain = -1;            // -1: a private one, 150..229 from the pid
  bool quiet = false;
  // false (default): without $CPGMATCH_KEYSTORE the study makes a private keystore and runs under
  // DDS-Security (private_keystore.hpp); true: plain DDS on loopback, readable and steerable by any local user.
  bool insecure = false;
  std::string progress_label; // printed before the progress bar ("replicate 2/5 ")
};

struct LocalStudyResult {
  study::StudyConfig config;
  std::filesystem::path dir;
  std::string store;
  int study_id = 0;
  int workers = 0;
  double wall_time_s = 0.0;
  bool secure = false;                  // ran under DDS-Security (a private or the given keystore)
  nlohmann::json state;                 // the last StudyState seen (to_json)
  std::vector<nlohmann::json> records;  // to_json(TrialRecord), as read over DDS
};

// The flags `study run` and `reproduce` share, and the options they give (validated: exit 2 naming the flag).
struct LocalStudyFlags {
  std::string config;
  int workers = 0;
  std::string out;
  int jitter = 12;
  bool quiet = false;
  bool insecure = false;

  void add_to(CLI::App& cmd, const std::string& out_help);
  LocalStudyOptions options() const;  // the study file (or the paper's) with workers, out and quiet set
};

// results/<prefix>-<local time>, e.g. results/paper-study-20261201-191855.
std::filesystem::path timestamped_results_dir(const std::string& prefix);

// The paper's study: every key but the name has the paper's value.
LocalStudyOptions paper_study_options();
// Options for a study file (its text is read here; load errors name the file).
LocalStudyOptions study_file_options(const std::string& path);

// Why a finished study measured nothing (every trial's outcome is neither completed nor fell: errors,
// divergences, refusals), or nothing when at least one trial measured a gait. `records`: to_json(TrialRecord).
std::optional<std::string> every_trial_failed(const std::vector<nlohmann::json>& records);

// Throws InputError for a study the service refuses, std::runtime_error when the service or every
// worker exits, on SIGINT/SIGTERM, or when the study ends other than done.
LocalStudyResult run_local_study(const LocalStudyOptions& options);

}  // namespace cpgmatch::cli
