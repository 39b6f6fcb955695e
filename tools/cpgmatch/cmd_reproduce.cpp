// `cpgmatch reproduce [--seeds N] [--out DIR] [--workers N] [--config STUDY.yaml]`: the paper's study N
// times, seeds 1..N, each exactly as `study run` runs it (local_study.hpp), then every statistic as
// mean ± sd over the seeds beside the paper's single run, replicates.json and the replicate figures.
#include <chrono>
#include <fstream>
#include <iostream>

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include "commands.hpp"
#include "cpgmatch/analysis/plots.hpp"
#include "cpgmatch/analysis/replicates.hpp"
#include "local_study.hpp"
#include "study_results.hpp"

namespace cpgmatch::cli {

namespace fs = std::filesystem;

namespace {

// The study file with its `seed` (and, so the replicates can be told apart, its name) replaced.
std::string with_seed(const std::string& text, const std::string& source, int seed) {
  YAML::Node node;
  try {
    node = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw InputError(fmt::format("{}: {}", source, e.what()));
  }
  node["seed"] = seed;
  node["name"] = fmt::format("{}-seed-{}", node["name"].as<std::string>(), seed);
  YAML::Emitter out;
  out << node;
  return fmt::format("# {} with seed {} (cpgmatch reproduce)\n{}\n", source, seed, out.c_str());
}

}  // namespace

void add_reproduce_command(CLI::App& app) {
  struct Options {
    int seeds = 5;
    std::string out;
    int workers = 0;
    std::string config;
    int jitter = 12;
    bool quiet = false;
  };
  auto opts = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand(
      "reproduce", "run the paper's study with seeds 1..N, each as `study run` does, and compare mean ± sd with the paper");
  cmd->add_option("--seeds", opts->seeds, "replicates, seeds 1..N (default 5)");
  cmd->add_option("--out", opts->out, "results directory (default: results/reproduce-<time>); one folder per seed inside");
  cmd->add_option("--workers", opts->workers, "simulation workers per study (default: number of cores)");
  cmd->add_option("--config", opts->config, "study YAML (default: the paper's study); its seed is replaced");
  cmd->add_option("--jitter", opts->jitter, "per replicate: re-run the best parameters N times under +-1% jitter");
  cmd->add_flag("--quiet", opts->quiet, "no progress on stderr");
  cmd->callback([opts] {
    if (opts->seeds < 1) throw InputError(fmt::format("--seeds {}: must be >= 1", opts->seeds));
    if (opts->workers < 0) throw InputError(fmt::format("--workers {}: must be >= 1", opts->workers));
    if (opts->jitter < 0) throw InputError(fmt::format("--jitter {}: must be >= 0", opts->jitter));
    const LocalStudyOptions base = opts->config.empty() ? paper_study_options() : study_file_options(opts->config);
    fs::path out = opts->out;
    if (out.empty()) {
      const auto stamp = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
      char buf[32];
      std::strftime(buf, sizeof(buf), "%Y%m%d-%H%M%S", std::localtime(&stamp));
      out = fs::path("results") / fmt::format("reproduce-{}", buf);
    }
    fs::create_directories(out);

    std::vector<analysis::StudyTrials> studies;
    std::vector<nlohmann::json> reports;
    for (int seed = 1; seed <= opts->seeds; ++seed) {
      LocalStudyOptions o = base;
      o.config_text = with_seed(base.config_text, base.config_source, seed);
      o.workers = opts->workers;
      o.out = out / fmt::format("seed-{}", seed);
      o.quiet = opts->quiet;
      o.progress_label = fmt::format("replicate {}/{} (seed {}) ", seed, opts->seeds, seed);
      const LocalStudyResult run = run_local_study(o);
      const StudyAnalysis a = write_study_results(run, opts->jitter, opts->quiet);
      if (!opts->quiet) {
        fmt::print(stderr, "replicate {}/{}: best cost {:.3f} (rollout {}), {} falls, J_feedback ratio {:.3f}\n", seed,
                   opts->seeds, a.report.best_cost, a.report.best_rollout, a.report.falls, a.report.feedback_ratio);
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
    fmt::print("results: {}  (replicates.json, replicates.txt, replicates_min_cost/replicates_feedback .png/.svg, seed-*/)\n",
               out.string());
  });
}

}  // namespace cpgmatch::cli
