// `cpgmatch optimize`: Bayesian optimisation of any black box given as a shell command, or of the
// simulated CPG rollout (`--objective rollout`).
#include <iostream>
#include <stdexcept>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "cpgmatch/robot_description_loader.hpp"
#include "robot_job.hpp"
#include "optimization_loop.hpp"
#include "optimizer_flags.hpp"
#include "progress.hpp"

namespace cpgmatch::cli {

namespace {

// `--objective rollout`: each point runs as a child process, `cpgmatch eval-rollout`.
std::string rollout_objective_command(const std::string& terrain, std::uint64_t seed, const std::string& robot,
                                      const std::string& preset, const std::string& gait) {
  std::string cmd = fmt::format("{} eval-rollout --terrain {} --seed {}", shell_quote(self_executable()),
                                shell_quote(terrain), seed);
  if (!robot.empty()) cmd += " --robot " + shell_quote(robot);
  if (!preset.empty()) cmd += " --preset " + shell_quote(preset);
  if (!gait.empty()) cmd += " --gait " + shell_quote(gait);
  return cmd;
}

}  // namespace

void add_optimize_command(CLI::App& app) {
  struct Options {
    OptimizerFlags flags;
    std::string space_file;
    std::string objective_cmd;
    std::string objective;
    double timeout_s = 600.0;
    std::string terrain = "flat";
    std::string robot, preset, gait;
  };
  auto opts = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand("optimize", "Bayesian optimisation of a black-box command or of the CPG");
  cmd->add_option("--space", opts->space_file, "search space YAML (default with --objective rollout: configs/spaces/paper.yaml, "
                                              "or the robot's search_space with --robot)");
  cmd->add_option("--objective-cmd", opts->objective_cmd, "shell command: point as JSON on stdin, cost on the last stdout line");
  cmd->add_option("--objective", opts->objective, "built-in objective: rollout");
  cmd->add_option("--timeout", opts->timeout_s, "seconds before an evaluation is killed and counted as failed");
  cmd->add_option("--terrain", opts->terrain, fmt::format("terrain for --objective rollout: {}", sim::TerrainSpec::syntax()));
  cmd->add_option("--robot", opts->robot, "with --objective rollout: a robot description (cpgmatch robot list, or a folder "
                                         "with robot.yaml) instead of configs/model/morti.yaml");
  cmd->add_option("--preset", opts->preset, "with --robot: the robot's preset giving every value not searched (default: its "
                                           "'default' preset)");
  cmd->add_option("--gait", opts->gait, "with --robot: one of the robot's gaits (default: trot if it has one, else its default)");
  opts->flags.add_to(cmd);
  cmd->callback([opts] {
    const auto options = opts->flags.to_options();
    if (!opts->objective.empty() && opts->objective != "rollout") {
      throw InputError(fmt::format("--objective '{}': the only built-in objective is 'rollout'", opts->objective));
    }
    const bool rollout = opts->objective == "rollout";
    if (rollout == !opts->objective_cmd.empty()) {
      throw InputError("give exactly one of --objective-cmd \"CMD\" or --objective rollout");
    }
    if (!(opts->timeout_s > 0.0)) throw InputError("--timeout must be > 0");
    if ((!opts->robot.empty() || !opts->preset.empty() || !opts->gait.empty()) && !rollout) {
      throw InputError("--robot, --preset and --gait go with --objective rollout");
    }
    if ((!opts->preset.empty() || !opts->gait.empty()) && opts->robot.empty()) {
      throw InputError("--preset and --gait need --robot NAME|DIR");
    }
    bo::SearchSpace space;
    if (!opts->space_file.empty()) {
      space = bo::SearchSpace::load(opts->space_file);
    } else if (!opts->robot.empty()) {
      // Checked here, before any child runs, so a bad robot, preset or gait fails once with its own message.
      sim::SimRolloutJob probe;
      const RobotDescription robot = load_robot(opts->robot);
      apply_robot(probe, robot, opts->preset, opts->gait);
      space = robot_search_space(robot, opts->preset);
    } else {
      if (!rollout) throw InputError("--space SPACE.yaml is required with --objective-cmd");
      space = bo::SearchSpace::load(sim::config_dir() + "/spaces/paper.yaml");
    }
    const std::string command =
        rollout ? rollout_objective_command(opts->terrain, opts->flags.seed, opts->robot, opts->preset, opts->gait)
                : opts->objective_cmd;

    bo::BayesianOptimizer optimizer(space, options);
    ProgressLine progress(opts->flags.budget, opts->flags.quiet);
    nlohmann::json evaluations = nlohmann::json::array();
    double best = std::numeric_limits<double>::infinity();
    int failed = 0;
    std::string first_failure;
    const Evaluator evaluate = command_evaluator(space, command, opts->timeout_s);
    run_optimization(optimizer, opts->flags.budget, opts->flags.batch, evaluate, [&](const Trial& t) {
      const nlohmann::json params = named_point_json(space, t.x);
      std::string note;
      if (t.outcome.ok) {
        best = std::min(best, t.outcome.cost);
        note = fmt::format("cost {:.6g}", t.outcome.cost);
      } else {
        if (failed++ == 0) first_failure = t.outcome.message;
        note = fmt::format("FAILED: {}", t.outcome.message);
        if (!opts->flags.quiet) fmt::print(stderr, "evaluation {} failed: {} (params {})\n", t.index, t.outcome.message, params.dump());
      }
      evaluations.push_back({{"index", t.index}, {"params", params}, {"ok", t.outcome.ok},
                             {"cost", t.outcome.ok ? nlohmann::json(t.outcome.cost) : nlohmann::json(nullptr)},
                             {"error", t.outcome.ok ? nlohmann::json(nullptr) : nlohmann::json(t.outcome.message)}});
      progress.update(t.index + 1, best, note);
    });

    const auto best_obs = optimizer.best();
    const nlohmann::json best_params = best_obs ? named_point_json(space, best_obs->x) : nlohmann::json(nullptr);
    if (opts->flags.json) {
      std::cout << nlohmann::json{{"best", best_obs ? nlohmann::json(best_obs->y) : nlohmann::json(nullptr)},
                                  {"best_params", best_params}, {"evaluations", evaluations.size()},
                                  {"failed", failed}, {"wall_time_s", progress.elapsed_s()}, {"trials", evaluations}}
                       .dump()
                << std::endl;
    } else if (best_obs) {
      fmt::print("best cost {:.6g} after {} evaluations ({} failed), {:.1f} s\n  params {}\n", best_obs->y,
                 evaluations.size(), failed, progress.elapsed_s(), best_params.dump());
    } else {
      fmt::print("no successful evaluation in {} ({} failed)\n", evaluations.size(), failed);
    }
    // Nothing was learnt: a script must not take this run for a result (the output above still tells
    // what was tried). Exit 1, a failed run, not 2: the flags were fine, the objective failed.
    if (!best_obs) {
      throw std::runtime_error(fmt::format("every evaluation failed ({} of {}), so there is no result; the first: {}",
                                           failed, evaluations.size(), first_failure));
    }
  });
}

}  // namespace cpgmatch::cli
