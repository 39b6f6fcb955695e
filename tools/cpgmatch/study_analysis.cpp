#include "study_analysis.hpp"

#include <unistd.h>

#include <cmath>

#include <fmt/format.h>

#include "cpgmatch/analysis/gnuplot.hpp"
#include "cpgmatch/analysis/plots.hpp"
#include "cpgmatch/analysis/sim2real.hpp"
#include "cpgmatch/analysis/stored_study_trials.hpp"
#include "cpgmatch/sim/sim_rollout.hpp"
#include "cpgmatch/study/spec_rollout.hpp"

namespace cpgmatch::cli {

namespace fs = std::filesystem;

namespace {

sim::SimRolloutJob study_job(const study::StudySpec& spec, const std::map<std::string, double>& params,
                             std::uint64_t seed) {
  const study::StudyConfig& cfg = spec.config();
  return study::sim_job_for(spec, params, cfg.terrain, seed, cfg.entrain_s, cfg.eval_s);
}

}  // namespace

std::shared_ptr<const study::StudySpec> stored_spec(const study::StoredStudy& stored) {
  if (stored.spec.json.empty()) {
    // Not yet opened by an optimizer that knows specs: this release's defaults, as its migration would do.
    return std::make_shared<const study::StudySpec>(
        study::StudySpec::resolve(stored.config_yaml, stored.source_name, study::SpecDefaults::shipped()));
  }
  return std::make_shared<const study::StudySpec>(
      study::StudySpec::from_json_text(stored.spec.json, fmt::format("study {} spec", stored.study_id)));
}

// Jitter rollouts run the study's own spec: a study of a stiffer knee is re-evaluated on that knee.
analysis::RolloutEvaluator sim_evaluator(std::shared_ptr<const study::StudySpec> spec) {
  return [spec](const std::map<std::string, double>& params, std::uint64_t seed) {
    try {
      const RolloutResult r = sim::run_sim_rollout(study_job(*spec, params, seed));
      return analysis::RolloutOutcome{true, r.fell, r.cost};
    } catch (const std::exception& e) {
      fmt::print(stderr, "jitter rollout failed: {}\n", e.what());
      return analysis::RolloutOutcome{false, false, std::nan("")};
    }
  };
}

StudyAnalysis analyse_stored_study(const study::StoredStudy& stored, int jitter_draws, bool quiet) {
  StudyAnalysis a;
  a.spec = stored_spec(stored);
  a.config = a.spec->config();
  const analysis::StudyTrials all = analysis::trials_from_stored_study(stored);
  a.trials = analysis::exploration_trials(all);  // a mixed study's hardware sets are reported apart
  a.report = analysis::science_report(a.trials);
  if (jitter_draws > 0 && a.report.best_rollout > 0) {
    analysis::JitterOptions o;
    o.draws = jitter_draws;
    o.rollout_seed = a.trials.seed;
    const auto evaluate = sim_evaluator(a.spec);
    int done = 0;
    const bool tty = isatty(STDERR_FILENO);
    if (!quiet && !tty) fmt::print(stderr, "jitter test of the recommended parameters: {} rollouts\n", jitter_draws);
    a.report.jitter = analysis::jitter_best(
        analysis::answer_params(a.report), a.trials.bounds,
        [&](const std::map<std::string, double>& p, std::uint64_t seed) {
          ++done;
          if (!quiet && tty) fmt::print(stderr, "\rjitter test of the recommended parameters: rollout {}/{}", done, jitter_draws);
          return evaluate(p, seed);
        },
        o);
    if (!quiet && tty) fmt::print(stderr, "\n");
  }
  a.json = analysis::to_json(a.report);
  const analysis::Sim2RealTable table = analysis::sim2real_table(all);
  a.has_hardware = table.hw_rollouts > 0;
  if (a.has_hardware) {
    a.json["sim2real"] = analysis::sim2real_json(table);
    a.sim2real_text = fmt::format("\n{}", analysis::sim2real_text(table));
    a.all_trials = all;
  }
  return a;
}

void print_figure_report(const analysis::FigureReport& report) {
  for (const auto& why : report.not_drawn) fmt::print(stderr, "not drawn: {}\n", why);
  for (const auto& error : report.failed) fmt::print(stderr, "figure failed: {}\n", error);
}

analysis::FigureReport write_study_figures(const fs::path& dir, const StudyAnalysis& a, bool trace_best, bool quiet) {
  analysis::FigureReport all;
  auto failed = [&](const std::string& what, const std::exception& e) {
    fmt::print(stderr, "{}: {}\n", what, e.what());
    all.failed.push_back(fmt::format("{}: {}", what, e.what()));
  };
  try {
    all = analysis::plot_study(a.trials, dir);
    if (!quiet) print_figure_report(all);
    if (quiet) for (const auto& error : all.failed) fmt::print(stderr, "figure failed: {}\n", error);
  } catch (const std::exception& e) {
    failed("figures", e);
  }
  if (a.has_hardware) {
    try {
      for (auto& f : analysis::plot_sim2real(a.all_trials, dir)) all.files.push_back(std::move(f));
    } catch (const std::exception& e) {
      failed("sim2real figure", e);
    }
  }
  if (!trace_best || a.report.best_rollout <= 0) return all;
  try {
    const fs::path trace = fs::absolute(dir) / "best_trace.csv";
    const sim::SimRolloutJob job = study_job(*a.spec, analysis::answer_params(a.report), a.trials.seed);
    sim::run_sim_rollout(job, make_csv_trace(trace.string(), job.settings.controller.legs.names));
    for (auto& f : analysis::plot_trace(trace, dir)) all.files.push_back(std::move(f));
  } catch (const std::exception& e) {
    failed("fig4", e);
  }
  if (!quiet && all.failed.empty()) fmt::print(stderr, "figures written to {}\n", fs::absolute(dir).string());
  return all;
}

}  // namespace cpgmatch::cli
