// `cpgmatch robot list|check|init`: which robots ship, whether a robot description holds together (and
// stands and walks in simulation), and a robot.yaml skeleton for a new robot from its URDF.
#include <filesystem>
#include <fstream>
#include <iostream>

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "robot_skeleton.hpp"
#include "cpgmatch/robot_description_loader.hpp"
#include "cpgmatch/sim/ode_plant.hpp"
#include "cpgmatch/sim/planar_leg_model.hpp"
#include "cpgmatch/text.hpp"
#include "cpgmatch/yaml_reader.hpp"

namespace cpgmatch::cli {
namespace {

namespace fs = std::filesystem;

struct StandResult {
  double start_height_m = 0.0, end_height_m = 0.0, end_pitch_rad = 0.0, end_roll_rad = 0.0;
  bool stood = false;
};

// Holds every joint at its standing target for `seconds` and reports whether the trunk stayed up.
StandResult stand(const sim::PlanarLegModel& model, double seconds) {
  sim::OdePlant plant(model, sim::TerrainSpec{}, 0);
  const PerLeg<JointCommand> hold(model.leg_count());
  plant.command(hold);
  StandResult r;
  r.start_height_m = plant.state().trunk.height_m;
  plant.advance(seconds);
  const PlantState s = plant.state();
  r.end_height_m = s.trunk.height_m;
  r.end_pitch_rad = s.trunk.pitch_rad;
  r.end_roll_rad = s.trunk.roll_rad;
  r.stood = s.trunk.height_m > 0.5 * r.start_height_m && std::abs(s.trunk.pitch_rad) < 0.3 &&
            std::abs(s.trunk.roll_rad) < 0.3;
  return r;
}

int check(const std::string& which, bool json) {
  const RobotDescription robot = load_robot(which);
  nlohmann::json out;
  out["name"] = robot.name;
  out["yaml"] = robot.yaml_source;
  out["urdf"] = robot.urdf_source;
  out["total_mass_kg"] = robot.total_mass_kg();
  out["standing_height_m"] = sim::standing_trunk_height_m(robot);
  if (!json) {
    fmt::print("robot {}: {}\n", robot.name, robot.summary);
    fmt::print("  files            {} + {}\n", robot.yaml_source, robot.urdf_source);
    fmt::print("  total mass       {:.3f} kg ({} links)\n", robot.total_mass_kg(), robot.links.size());
    fmt::print("  standing height  {:.3f} m (trunk origin above flat ground, URDF pose)\n", sim::standing_trunk_height_m(robot));
    fmt::print("  legs             {} in groups {}\n", robot.legs.size(), fmt::join(robot.groups, ", "));
  }
  for (const LegDescription& leg : robot.legs) {
    out["legs"].push_back({{"name", leg.name}, {"group", leg.group}, {"hip", leg.hip_joint}, {"knee", leg.knee_joint},
                           {"ankle", leg.ankle_joint}, {"foot", leg.foot_link}});
    if (!json) {
      fmt::print("    {:<6} {:<7} hip {}, knee {}{}, foot {}\n", leg.name, leg.group, leg.hip_joint, leg.knee_joint,
                 leg.ankle_joint.empty() ? "" : ", ankle " + leg.ankle_joint, leg.foot_link);
    }
  }
  for (const auto& [role, drive] : robot.drives) {
    nlohmann::json d{{"role", role}, {"kind", to_string(drive.kind)}};
    std::string motor_text = "no motor";
    if (!drive.motor.empty()) {
      const MotorDescription& m = robot.motors.at(drive.motor);
      d["motor"] = {{"name", m.name}, {"stall_torque_nm", m.stall_torque_nm}, {"no_load_speed_rad_s", m.no_load_speed_rad_s},
                    {"gear_ratio", m.gear_ratio}};
      motor_text = fmt::format("motor {} ({} N m stall, {} rad/s no-load, ratio {})", m.name, m.stall_torque_nm,
                               m.no_load_speed_rad_s, m.gear_ratio);
    }
    out["drives"].push_back(d);
    if (!json) fmt::print("  {:<5} joints    {}, {}\n", role, to_string(drive.kind), motor_text);
  }
  if (!json) fmt::print("  gaits            {}\n", [&] {
    std::string s;
    for (const auto& g : robot.gaits) s += (s.empty() ? "" : ", ") + g.name;
    return s;
  }());
  if (!json) fmt::print("  search space\n");
  for (const SearchParameter& p : robot.search_space) {
    out["search_space"].push_back({{"name", p.name}, {"low", p.low}, {"high", p.high}, {"unit", p.unit}});
    if (!json) fmt::print("    {:<20} [{}, {}] {}\n", p.name, p.low, p.high, p.unit);
  }

  // Simulation: what this version's plant builds of it, a 3-s stand and each preset.
  try {
    const sim::PlanarLegModel model = sim::planar_leg_model(robot);
    const StandResult s = stand(model, 3.0);
    out["planar"] = model.planar;
    out["stand"] = {{"start_height_m", s.start_height_m}, {"end_height_m", s.end_height_m},
                    {"end_pitch_rad", s.end_pitch_rad}, {"end_roll_rad", s.end_roll_rad}, {"stood", s.stood}};
    if (!json) {
      fmt::print("  simulated as     {}\n", model.planar ? "planar (a rail or boom: forward, up, pitch)" : "free in 3D");
      fmt::print("  standing 3 s     {}: trunk {:.3f} m -> {:.3f} m, pitch {:+.3f} rad, roll {:+.3f} rad\n",
                 s.stood ? "stood" : "FELL", s.start_height_m, s.end_height_m, s.end_pitch_rad, s.end_roll_rad);
    }
    for (const auto& [name, values] : robot.presets) {
      sim::SimRolloutJob job = make_sim_job("", {}, "", "", "flat", 0);
      job.model = model;
      apply_robot_legs(job.settings.controller, robot);
      for (const auto& [key, value] : values) set_parameter(job.params, key, value, name);
      const RolloutResult r = sim::run_sim_rollout(job);
      out["presets"].push_back({{"name", name}, {"cost", r.cost}, {"fell", r.fell}, {"outcome", to_string(r.outcome)},
                                {"speed_mps", r.breakdown.mean_speed_mps}, {"feedback", r.breakdown.terms.feedback}});
      if (!json) {
        fmt::print("  preset {:<13} {}: cost {:.3f}, {:.3f} m/s, J_feedback {:.3f}\n", name,
                   r.fell ? "FELL" : to_string(r.outcome), r.cost, r.breakdown.mean_speed_mps, r.breakdown.terms.feedback);
      }
    }
  } catch (const InputError& e) {
    out["simulation"] = e.what();
    if (!json) fmt::print("  simulation       not built by this version: {}\n", e.what());
  }
  if (json) std::cout << out.dump() << std::endl;
  return 0;
}

int init(const std::string& urdf_path, const std::string& out_dir, bool force) {
  const std::string text = read_text_file(urdf_path, "--urdf", kMaxYamlBytes);
  const UrdfModel urdf = parse_urdf(text, urdf_path);
  const fs::path dir(out_dir);
  if (fs::exists(dir / "robot.yaml") && !force) {
    throw InputError(fmt::format("--out: '{}' already holds a robot.yaml (--force overwrites it)", escape_for_message(out_dir)));
  }
  fs::create_directories(dir);
  const std::string urdf_name = "robot.urdf";
  if (fs::weakly_canonical(urdf_path) != fs::weakly_canonical(dir / urdf_name)) {
    std::ofstream(dir / urdf_name) << text;
  }
  std::ofstream(dir / "robot.yaml") << robot_yaml_skeleton(urdf, urdf_name);
  const auto legs = guess_legs(urdf);
  fmt::print("wrote {}/robot.yaml and {}/{}: {} links, {} joints, {} leg(s) guessed\n", out_dir, out_dir, urdf_name,
             urdf.links.size(), urdf.joints.size(), legs.size());
  for (const auto& l : legs) {
    fmt::print("  {:<12} {:<7} hip {}, knee {}{}, foot {}\n", l.name, l.group, l.hip, l.knee.empty() ? "?" : l.knee,
               l.ankle.empty() ? "" : ", ankle " + l.ankle, l.foot);
  }
  fmt::print("next: fill in every FILL_IN in {}/robot.yaml, then `cpgmatch robot check {}` (docs/your-robot.md)\n", out_dir, out_dir);
  return 0;
}

}  // namespace

void add_robot_command(CLI::App& app) {
  CLI::App* robot = app.add_subcommand("robot", "robot descriptions: list the shipped ones, check one, start one from a URDF");
  robot->require_subcommand(1);

  CLI::App* list = robot->add_subcommand("list", "the shipped robots (configs/robots/NAME/)");
  auto list_json = std::make_shared<bool>(false);
  list->add_flag("--json", *list_json, "print one JSON array");
  list->callback([list_json] {
    nlohmann::json out = nlohmann::json::array();
    for (const std::string& name : shipped_robot_names()) {
      const RobotDescription r = load_robot(name);
      out.push_back({{"name", name}, {"legs", r.legs.size()}, {"total_mass_kg", r.total_mass_kg()}, {"summary", r.summary}});
      if (!*list_json) fmt::print("{:<18} {} legs, {:.2f} kg  {}\n", name, r.legs.size(), r.total_mass_kg(), r.summary);
    }
    if (*list_json) std::cout << out.dump() << std::endl;
  });

  CLI::App* check_cmd = robot->add_subcommand("check", "validate a robot description; print its mass, legs, joints, "
                                                       "search space, a 3-s standing rollout and each preset");
  auto which = std::make_shared<std::string>();
  auto check_json = std::make_shared<bool>(false);
  check_cmd->add_option("robot", *which, "a shipped robot's name, a folder with robot.yaml, or a robot.yaml")->required();
  check_cmd->add_flag("--json", *check_json, "print one JSON object");
  check_cmd->callback([which, check_json] { check(*which, *check_json); });

  CLI::App* init_cmd = robot->add_subcommand("init", "write a robot.yaml skeleton from a URDF: every joint and link named, "
                                                     "legs and feet guessed, FILL_IN where only you know the value");
  auto urdf = std::make_shared<std::string>();
  auto out = std::make_shared<std::string>();
  auto force = std::make_shared<bool>(false);
  init_cmd->add_option("--urdf", *urdf, "the robot's URDF")->required();
  init_cmd->add_option("--out", *out, "the folder to write robot.yaml (and a copy of the URDF) into")->required();
  init_cmd->add_flag("--force", *force, "overwrite an existing robot.yaml");
  init_cmd->callback([urdf, out, force] { init(*urdf, *out, *force); });
}

}  // namespace cpgmatch::cli
