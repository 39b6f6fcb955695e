// `cpgmatch reproduce [--seeds N] [--out DIR] [--workers N] [--config STUDY.yaml]`: the paper's study N
// times, seeds 1..N, each exactly as `study run` runs it (local_study.hpp), then every statistic as
// mean ± sd over the seeds beside the paper's single run, replicates.json and the replicate figures.
#include <chrono>
#include <fstream>
#include <iostream>
#include <limits>

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include "commands.hpp"
#include "cpgmatch/analysis/plots.hpp"
#include "cpgmatch/analysis/replicates.hpp"
#include "cpgmatch/yaml_reader.hpp"
#include "local_study.hpp"
#include "study_results.hpp"

namespace cpgmatch::cli {

namespace fs = std::filesystem;

namespace {

// The study file with its `seed` (and, so the replicates can be told apart, its name) replaced.
// Read through YamlReader, the one door for YAML text, not yaml-cpp directly: its checks (size, one document,
// closed quotes) hold here too, and a missing name is an InputError naming the field, not a yaml-cpp exception.
std::string with_seed(const std::string& text, const std::string& source, int seed) {
  const YamlReader reader = YamlReader::from_string(text, source);
  const std::string name = reader.require_string("name");
  YAML::Node node = reader.node();
  node["seed"] = seed;
  node["name"] = fmt::format("{}-seed-{}", name, seed);
  YAML::Emitter out;
  out << node;
  return fmt::format("# {} with seed {} (cpgmatch reproduce)\n{}\n", source, seed, out.c_str());
}

}  // namespace

void add_reproduce_command(CLI::App& app) {
  struct Options {
    int seeds = 5;
    int first_seed = 1;  // seeds first_seed .. first_seed + seeds - 1: more replicates without rerunning 1..N
    LocalStudyFlags common;  // --config (its seed is replaced), --workers, --out, --jitter, --quiet
  };
  auto opts = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand(
      "reproduce", "run the paper's study with seeds 1..N, each as `study run` does, and compare mean ± sd with the paper");
  cmd->add_option("--seeds", opts->seeds, "replicates, seeds 1..N (default 5)");
  cmd->add_option("--first-seed", opts->first_seed,
                  "first seed (default 1): seeds K..K+N-1, e.g. --first-seed 6 --seeds 5 adds seeds 6-10 to a "
                  "run of 1-5");
  opts->common.add_to(*cmd, "results directory (default: results/reproduce-<time>); one folder per seed inside");
  cmd->callback([opts] {
    if (opts->seeds < 1) throw InputError(fmt::format("--seeds {}: must be >= 1", opts->seeds));
    if (opts->first_seed < 0 || opts->first_seed > std::numeric_limits<int>::max() - opts->seeds + 1) {
      throw InputError(fmt::format("--first-seed {}: must be in [0, {}] with --seeds {}", opts->first_seed,
                                   std::numeric_limits<int>::max() - opts->seeds + 1, opts->seeds));
    }
    const LocalStudyOptions base = opts->common.options();
    const bool quiet = base.quiet;
    const int jitter = opts->common.jitter;
    const fs::path out = base.out.empty() ? timestamped_results_dir("reproduce") : base.out;
    fs::create_directories(out);

    std::vector<analysis::StudyTrials> studies;
    std::vector<nlohmann::json> reports;
    for (int k = 1; k <= opts->seeds; ++k) {
      const int seed = opts->first_seed + k - 1;
      LocalStudyOptions o = base;
      o.config_text = with_seed(base.config_text, base.config_source, seed);
      o.out = out / fmt::format("seed-{}", seed);
      o.progress_label = fmt::format("replicate {}/{} (seed {}) ", k, opts->seeds, seed);
      const LocalStudyResult run = run_local_study(o);
      const StudyAnalysis a = write_study_results(run, jitter, quiet);
      if (!quiet) {
        fmt::print(stderr, "replicate {}/{} (seed {}): best cost {:.3f} (rollout {}), {} falls, J_feedback ratio {:.3f}\n",
                   k, opts->seeds, seed, a.report.best_cost, a.report.best_rollout, a.report.falls,
                   a.report.feedback_ratio);
      }
      studies.push_back(a.trials);
      reports.push_back(a.json);
    }
    const analysis::ReplicateSummary summary = analysis::aggregate_replicates(reports);
    std::ofstream(out / "replicates.json") << analysis::to_json(summary).dump(2) << '\n';
    const std::string table = analysis::format_table(summary);
    std::ofstream(out / "replicates.txt") << table;
    fmt::print("{}", table);
    try {
      analysis::plot_replicates(studies, summary, out);
    } catch (const std::exception& e) {
      fmt::print(stderr, "replicate figures: {}\n", e.what());
    }
    fmt::print("results: {}  (replicates.json, replicates.txt, replicates_min_cost/replicates_feedback .png/.svg, seed-*/ each with its report.html)\n",
               out.string());
  });
}

}  // namespace cpgmatch::cli
