// `cpgmatch bench-optimizer`: the optimizer on a standard test function, reporting regret and speed.
#include <chrono>
#include <ctime>
#include <iostream>
#include <numeric>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "cpgmatch/bo/test_functions.hpp"
#include "optimizer_flags.hpp"
#include "progress.hpp"

namespace cpgmatch::cli {
namespace {

// CPU time of this thread, in ms: what a proposal costs on one core, whatever else the machine runs (the wall
// time of the same proposal grows with the load; both are reported).
double thread_cpu_ms() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) * 1e3 + static_cast<double>(t.tv_nsec) * 1e-6;
}

}  // namespace

void add_bench_optimizer_command(CLI::App& app) {
  auto flags = std::make_shared<OptimizerFlags>();
  auto function = std::make_shared<std::string>("branin");
  CLI::App* cmd = app.add_subcommand("bench-optimizer", "run the optimizer on a standard test function");
  cmd->add_option("--function", *function, "branin | hartmann3 | hartmann6 | ackley | rosenbrock | levy | styblinski-tang | ackley20 | levy20");
  flags->add_to(cmd);
  // The large-study knobs (OptimizerOptions), to measure what each one buys; the defaults are the library's.
  auto knobs = std::make_shared<bo::OptimizerOptions>();
  auto timings = std::make_shared<bool>(false);
  cmd->add_flag("--timings", *timings,
                "with --json: every proposal's CPU and wall ms (proposal_cpu_ms, proposal_ms; index k = the proposal made "
                "with k results told), to see the model's schedule and medians, not only the last one");
  cmd->add_option("--hyperparameter-growth", knobs->hyperparameter_growth,
                  "re-optimise the GP's hyperparameters once the data grew by this fraction (0: every tell)");
  cmd->add_option("--hyperparameter-max-points", knobs->hyperparameter_max_points,
                  "optimise the hyperparameters on at most this many points nearest the best (0: all)");
  cmd->add_option("--max-model-points", knobs->max_model_points,
                  "past this many observations the model is local: the ones nearest the best (0: all)");
  cmd->add_option("--batch-refined-points", knobs->batch_refined_points,
                  "points of a batch whose acquisition is refined; the rest are Thompson draws (0: all refined)");
  cmd->callback([flags, function, knobs, timings] {
    const bo::TestFunction tf = bo::test_function(*function);
    bo::OptimizerOptions options = flags->to_options();
    options.budget = flags->budget;  // as a study does: no model fit after the last result
    options.hyperparameter_growth = knobs->hyperparameter_growth;
    options.hyperparameter_max_points = knobs->hyperparameter_max_points;
    options.max_model_points = knobs->max_model_points;
    options.batch_refined_points = knobs->batch_refined_points;
    options.validate();
    // A log-modelled cost must stay > 0: refused before the run for a function whose minimum is not (it
    // used to stop mid-run with exit 2 at the first non-positive value).
    if (options.cost_transform == bo::CostTransform::kLog && !(tf.global_minimum > 0.0)) {
      throw InputError(fmt::format("--cost-transform log: {} reaches {} (its global minimum), and log needs costs > 0; "
                                   "use --cost-transform none",
                                   tf.name, tf.global_minimum));
    }
    bo::BayesianOptimizer opt(tf.space, options);
    ProgressLine progress(flags->budget, flags->quiet);
    const auto start = std::chrono::steady_clock::now();
    double best = std::numeric_limits<double>::infinity();
    int best_index = -1;
    double last_proposal_ms = 0.0, last_proposal_cpu_ms = 0.0, max_proposal_ms = 0.0, max_proposal_cpu_ms = 0.0;
    int done = 0;
    double last_tell_ms = 0.0, last_tell_cpu_ms = 0.0;
    std::vector<double> recent_cpu_ms;  // the last 10 proposals: the model's schedule amortised
    std::vector<double> all_cpu_ms, all_ms;
    while (done < flags->budget) {
      const int n = std::min(flags->batch, flags->budget - done);
      const auto t0 = std::chrono::steady_clock::now();
      const double c0 = thread_cpu_ms();
      const auto points = opt.ask(n);
      // Proposal time = the model update of the last tell plus this ask (what a worker waits for).
      const double ask_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
      last_proposal_ms = last_tell_ms + ask_ms;
      last_proposal_cpu_ms = last_tell_cpu_ms + (thread_cpu_ms() - c0);
      max_proposal_ms = std::max(max_proposal_ms, last_proposal_ms);
      max_proposal_cpu_ms = std::max(max_proposal_cpu_ms, last_proposal_cpu_ms);
      recent_cpu_ms.push_back(last_proposal_cpu_ms);
      all_cpu_ms.push_back(last_proposal_cpu_ms);
      all_ms.push_back(last_proposal_ms);
      if (recent_cpu_ms.size() > 10) recent_cpu_ms.erase(recent_cpu_ms.begin());
      // A long ask says so (a batch of hundreds at thousands of points takes seconds): a long run shows progress.
      if (n > 1 || ask_ms > 1000.0) {
        progress.update(done, best, fmt::format("asked {} points in {:.2f} s", n, ask_ms / 1e3));
      }
      // A batch's results are told together (one model update for all, as the service does with the
      // reports that arrive while its model is busy); one point is told alone, as always.
      std::vector<bo::Observation> results;
      for (const auto& x : points) {
        const double y = tf.f(x);
        results.push_back({x, y, false});
        if (y < best) {
          best = y;
          best_index = done;
        }
        ++done;
        if (n == 1) progress.update(done, best, fmt::format("y {:.6g}", y));
      }
      const auto t1 = std::chrono::steady_clock::now();
      const double c1 = thread_cpu_ms();
      if (results.size() == 1) opt.tell(results[0].x, results[0].y);
      else opt.tell_batch(results);
      last_tell_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t1).count();
      last_tell_cpu_ms = thread_cpu_ms() - c1;
      if (n > 1) progress.update(done, best, fmt::format("told {} results in {:.2f} s", n, last_tell_ms / 1e3));
    }
    const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (flags->json) {
      nlohmann::json j{{"function", tf.name}, {"seed", flags->seed}, {"budget", flags->budget},
                       {"initial", flags->initial}, {"acq", flags->acquisition}, {"best", best},
                       {"regret", best - tf.global_minimum}, {"best_index", best_index},
                       {"batch", flags->batch}, {"wall_time_s", wall}, {"proposal_ms_last", last_proposal_ms},
                       {"proposal_cpu_ms_last", last_proposal_cpu_ms}, {"proposal_ms_max", max_proposal_ms},
                       {"proposal_cpu_ms_max", max_proposal_cpu_ms},
                       {"proposal_cpu_ms_mean_last10", std::accumulate(recent_cpu_ms.begin(), recent_cpu_ms.end(), 0.0) /
                                                           std::max<std::size_t>(1, recent_cpu_ms.size())}};
      if (*timings) {
        j["proposal_cpu_ms"] = all_cpu_ms;
        j["proposal_ms"] = all_ms;
      }
      std::cout << j.dump() << std::endl;
    } else {
      fmt::print("{}: best {:.8g} (regret {:.3g}) at evaluation {}; {:.2f} s wall; last proposal {:.1f} ms\n",
                 tf.name, best, best - tf.global_minimum, best_index, wall, last_proposal_ms);
    }
  });
}

}  // namespace cpgmatch::cli
