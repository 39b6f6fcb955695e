// `cpgmatch eval-rollout` (internal): one rollout whose parameters arrive as a JSON object on stdin.
// Prints the full result as one JSON line, then the cost alone on the last line, so it serves both as
// an objective command for `optimize` and as the rollout worker of `study run`.
#include <iostream>
#include <iterator>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "cpgmatch/robot_description_loader.hpp"
#include "robot_job.hpp"
#include "rollout_json.hpp"

namespace cpgmatch::cli {

void add_eval_rollout_command(CLI::App& app) {
  struct Options {
    std::string settings_file, model_file, robot, preset, gait, terrain = "flat";
    std::uint64_t seed = 0;
    double entrain_s = -1.0, eval_s = -1.0;
  };
  auto opts = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand("eval-rollout", "internal: rollout with parameters as JSON on stdin");
  cmd->group("");  // hidden from --help
  cmd->add_option("--settings", opts->settings_file);
  CLI::Option* model = cmd->add_option("--model", opts->model_file);
  // A robot description instead of the model file: its plant, legs and gaits, and its preset as the base values
  // the point's parameters override (default: its "default" preset, if it has one).
  cmd->add_option("--robot", opts->robot)->excludes(model);
  cmd->add_option("--preset", opts->preset);
  cmd->add_option("--gait", opts->gait);
  cmd->add_option("--terrain", opts->terrain);
  cmd->add_option("--seed", opts->seed);
  cmd->add_option("--entrain", opts->entrain_s);
  cmd->add_option("--eval", opts->eval_s);
  cmd->callback([opts] {
    const std::string input((std::istreambuf_iterator<char>(std::cin)), std::istreambuf_iterator<char>());
    nlohmann::json point;
    try {
      point = nlohmann::json::parse(input);
    } catch (const nlohmann::json::exception& e) {
      throw InputError(fmt::format("stdin: not a JSON object of parameters: {}", e.what()));
    }
    if (!point.is_object()) throw InputError("stdin: expected a JSON object {\"name\": value, ...}");
    sim::SimRolloutJob job = make_sim_job("", {}, opts->settings_file, opts->model_file, opts->terrain, opts->seed);
    if (!opts->robot.empty()) {
      apply_robot(job, load_robot(opts->robot), opts->preset, opts->gait);
    } else if (!opts->preset.empty() || !opts->gait.empty()) {
      throw InputError("--preset and --gait need --robot NAME|DIR");
    }
    for (const auto& [name, value] : point.items()) {
      if (!value.is_number()) throw InputError(fmt::format("stdin: parameter '{}' must be a number", name));
      set_parameter(job.params, name, value.get<double>(), "stdin");
    }
    if (opts->entrain_s >= 0.0) job.settings.entrain_s = opts->entrain_s;
    if (opts->eval_s > 0.0) job.settings.eval_s = opts->eval_s;
    const RolloutResult r = sim::run_sim_rollout(job);
    std::cout << to_json(r).dump() << '\n' << fmt::format("{:.17g}", r.cost) << std::endl;
  });
}

}  // namespace cpgmatch::cli
