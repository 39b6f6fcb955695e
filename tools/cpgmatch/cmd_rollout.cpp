// `cpgmatch rollout`: one simulated rollout with a readable summary or one JSON object.
#include <cstdio>
#include <iostream>

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include "flag_checks.hpp"
#include "commands.hpp"
#include "cpgmatch/robot_description_loader.hpp"
#include "cpgmatch/sim/planar_leg_model.hpp"
#include "cpgmatch/sim/sim_rollout.hpp"
#include "rollout_json.hpp"

namespace cpgmatch::cli {
namespace {

struct RolloutOptions {
  std::string params_file;
  std::vector<std::string> assignments;
  std::string settings_file;
  std::string model_file;
  std::string robot;
  std::string terrain = "flat";
  std::uint64_t seed = 0;
  bool no_feedback = false;
  std::vector<std::string> disable;
  double entrain_s = -1.0;
  double eval_s = -1.0;
  double treadmill_mps = 0.0;
  std::string trace_file;
  bool json = false;
};

void print_summary(const RolloutResult& r, const sim::SimRolloutJob& job) {
  const auto& b = r.breakdown;
  fmt::print("rollout on {} terrain, seed {}, {:.1f} s simulated in {:.3f} s wall\n", job.terrain.describe(),
             job.seed, r.sim_time_s, r.wall_time_s);
  if (r.fell) fmt::print("  FELL at t = {:.2f} s -> fall cost\n", r.fall_time_s);
  if (r.outcome == RolloutOutcome::kDiverged || r.outcome == RolloutOutcome::kPlantFault) {
    fmt::print("  {}: {} (not a result: a study re-runs such a trial)\n", to_string(r.outcome), r.outcome_message);
  }
  fmt::print("  cost               {:8.4f}\n", r.cost);
  fmt::print("    J_feedback       {:8.4f}   (LTD {:.1f}%  ETD {:.1f}%  ETO {:.1f}%  LTO {:.1f}%)\n", b.terms.feedback,
             100 * b.feedback_fraction.late_touchdown, 100 * b.feedback_fraction.early_touchdown,
             100 * b.feedback_fraction.early_toeoff, 100 * b.feedback_fraction.late_toeoff);
  fmt::print("    J_distance       {:8.4f}   (1/m; walked {:.3f} m, {:.3f} m/s)\n", b.terms.distance, b.distance_m,
             b.mean_speed_mps);
  fmt::print("    J_pitch          {:8.4f}   (rad)\n", b.terms.pitch);
  fmt::print("    J_contact        {:8.4f}\n", b.terms.contact);
  fmt::print("    J_periodicity    {:8.4f}   (Hz)\n", b.terms.periodicity);
  fmt::print("  normalized torque  {:8.4f}   (N m / (m/s), eq. 1: sum of mean |torque| / speed)\n", b.normalized_torque);
  const EnergyMeasures& e = r.energy;
  fmt::print("  signed torque      {:8.4f}   (N m / (m/s): sum of |signed mean torque| / speed)\n",
             e.signed_torque_per_speed);
  fmt::print("  positive work      {:8.4f}   (J/m; hips {:.4f}, knees {:.4f})\n", e.positive_work_j_per_m,
             e.hip_positive_work_j_per_m, e.knee_positive_work_j_per_m);
  fmt::print("  electrical energy  {:8.4f}   (J over the evaluation; Joule loss {:.3f} J)\n", e.electrical_j,
             e.joule_loss_j);
  fmt::print("  cost of transport  {:8.4f}   (electrical; mechanical {:.4f})\n", e.electrical_cost_of_transport,
             e.mechanical_cost_of_transport);
  if (r.hip_tracking_rms_rad >= 0.0) {
    fmt::print("  hip tracking       {:8.4f}   (rad, RMS of command minus hip angle after the start-up ramp)\n",
               r.hip_tracking_rms_rad);
  }
}

}  // namespace

void add_rollout_command(CLI::App& app) {
  auto opts = std::make_shared<RolloutOptions>();
  CLI::App* cmd = app.add_subcommand("rollout", "run one simulated rollout locally");
  cmd->add_option("--params", opts->params_file, "parameter YAML (default: configs/params/default.yaml)");
  cmd->add_option("--set", opts->assignments, "override one parameter, name=value (repeatable)");
  cmd->add_option("--settings", opts->settings_file, "rollout settings YAML (default: configs/rollout.yaml)");
  CLI::Option* model = cmd->add_option("--model", opts->model_file, "robot model YAML (default: configs/model/morti.yaml)");
  cmd->add_option("--robot", opts->robot, "a robot description: a shipped robot's name (cpgmatch robot list) or a folder with robot.yaml")
      ->excludes(model);
  cmd->add_option("--terrain", opts->terrain, sim::TerrainSpec::syntax());
  cmd->add_option("--seed", opts->seed, "seed for terrain roughness and sensor noise")->check(whole_non_negative());
  cmd->add_flag("--no-feedback", opts->no_feedback, "switch off all feedback mechanisms (ablation)");
  cmd->add_option("--disable", opts->disable, "switch off one mechanism: ltd, etd, eto (repeatable)");
  // Bounds: a rollout longer than an hour of simulated time is a typo, not an experiment; a belt beyond
  // 5 m/s is ten times the robot's top speed.
  cmd->add_option("--entrain", opts->entrain_s, "entrainment time, seconds")->check(finite_in(0.0, 3600.0, "s"));
  cmd->add_option("--eval", opts->eval_s, "evaluation time, seconds")->check(finite_in(0.01, 3600.0, "s"));
  cmd->add_option("--treadmill", opts->treadmill_mps, "treadmill belt speed, m/s (0 = fixed ground)")
      ->check(finite_in(-5.0, 5.0, "m/s"));
  cmd->add_option("--trace", opts->trace_file, "write the time series to this CSV file");
  cmd->add_flag("--json", opts->json, "print exactly one JSON object");
  cmd->callback([opts] {
    sim::SimRolloutJob job = make_sim_job(opts->params_file, opts->assignments, opts->settings_file,
                                          opts->model_file, opts->terrain, opts->seed);
    if (!opts->robot.empty()) {
      const RobotDescription robot = load_robot(opts->robot);
      job.model = sim::planar_leg_model(robot);
      apply_robot_legs(job.settings.controller, robot);
    }
    if (opts->entrain_s >= 0.0) job.settings.entrain_s = opts->entrain_s;
    if (opts->eval_s > 0.0) job.settings.eval_s = opts->eval_s;
    job.terrain.treadmill_speed_mps = opts->treadmill_mps;
    if (opts->no_feedback) job.settings.controller.feedback = FeedbackConfig::none();
    for (const auto& m : opts->disable) {
      auto& fb = job.settings.controller.feedback;
      if (m == "ltd") fb.late_touchdown = false;
      else if (m == "etd") fb.early_touchdown = false;
      else if (m == "eto") fb.early_toeoff = false;
      else throw InputError(fmt::format("--disable '{}': expected ltd, etd or eto", m));
    }
    TraceSink trace;
    if (!opts->trace_file.empty()) trace = make_csv_trace(opts->trace_file, job.settings.controller.legs.names);
    const RolloutResult r = sim::run_sim_rollout(job, trace);
    if (opts->json) {
      std::cout << to_json(r).dump() << std::endl;
    } else {
      print_summary(r, job);
    }
  });
}

sim::SimRolloutJob make_sim_job(const std::string& params_file, const std::vector<std::string>& assignments,
                                const std::string& settings_file, const std::string& model_file,
                                const std::string& terrain, std::uint64_t seed) {
  sim::SimRolloutJob job;
  job.params = load_parameters(params_file.empty() ? sim::default_params_path() : params_file);
  for (const auto& a : assignments) apply_assignment(job.params, a);
  job.settings = load_rollout_settings(settings_file.empty() ? sim::default_rollout_settings_path() : settings_file);
  job.model = sim::load_model_file(model_file.empty() ? sim::default_model_path() : model_file);
  job.terrain = sim::TerrainSpec::parse(terrain);
  job.seed = seed;
  return job;
}

}  // namespace cpgmatch::cli
