// cpgmatch-robot-emulator: a robot in ODE behind its motor and sensor protocol on a CAN bus, so the agent
// runs end to end without hardware: timing, protocol, safety and all.
//
//   cpgmatch-robot-emulator --can udp:127.0.0.1:47000 [--model BODY] [--robot HARDWARE.yaml]
//
// --robot is the hardware description the agent drives (configs/robot/*.yaml: joints, CAN ids, protocols).
// --model is the simulated body: a robot description (a shipped robot's name, its folder or its robot.yaml)
// or a model file (configs/model/*.yaml, Morti's reality-gap scenarios). Without it, the robot description
// the hardware file names in `robot:` (odrive-quadruped's hardware walks on odrive-quadruped's body), or
// Morti's model file when the hardware file names none. --switch-model-at N:BODY changes the body between
// rollouts N and N + 1 (a robot that wears, is loaded or walks onto another floor mid-study).
//
// Real time (default): physics steps at the model's rate against the wall clock; each motor answers its
// command at once with its latest state, like a motor driver; the sensor nodes stream every control
// period. --lockstep instead steps one control period of physics whenever every motor has been
// commanded, then answers: bit-for-bit the sequence of a direct simulation, whatever the load.
//
// A rollout starts when the motors are enabled after all were off: the robot is put back on its feet
// (a fresh world), as an operator would. While every motor is off the robot hangs in its rig (no
// physics), so it cannot collapse between rollouts.
#include <algorithm>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include "cpgmatch/can/can_bus.hpp"
#include "cpgmatch/errors.hpp"
#include "cpgmatch/robot/realtime.hpp"
#include "cpgmatch/robot_description_loader.hpp"
#include "cpgmatch/robot/robot_config.hpp"
#include "cpgmatch/robot/robot_device.hpp"
#include "cpgmatch/runtime/install_layout.hpp"
#include "cpgmatch/runtime/man_pages.hpp"
#include "cpgmatch/runtime/shared_flags.hpp"
#include "cpgmatch/sim/ode_plant.hpp"
#include "cpgmatch/sim/planar_leg_model.hpp"
#include "cpgmatch/sim/sim_rollout.hpp"
#include "cpgmatch/yaml_reader.hpp"

namespace cpgmatch::robot {
namespace {

volatile std::sig_atomic_t g_stop = 0;
void on_signal(int) { g_stop = 1; }

struct Options {
  std::string can_uri;
  std::string model_path;
  std::string robot_path;
  std::string terrain = "flat";
  std::uint64_t seed = 0;
  bool lockstep = false;
  DeviceImperfections imperfections;
  double latency_ms = 0.0;
  double extra_friction_nm = 0.0;
  double driver_timeout_ms = 100.0;  // the motor drivers' own command watchdog (RobotDevice::enforce_command_timeout)
  std::vector<std::string> body_switches;  // --switch-model-at N:BODY
};

// Whether --model names a robot description rather than a model file: a shipped robot's name, a folder, or a
// YAML file with the robot description's `legs:` or an overlay's `base:` (a model file has neither).
bool names_robot_description(const std::string& body) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (fs::is_directory(body, ec) || (names_shipped_robot(body) && !fs::exists(body, ec))) return true;
  const YamlReader yaml = YamlReader::from_file(body);
  return yaml.has("legs") || yaml.has("base");  // a robot.yaml or an overlay on one
}

// The body the emulator simulates (see the header comment for the choice without --model).
sim::PlanarLegModel simulated_body(const std::string& body, const RobotConfig& hardware) {
  if (body.empty()) {
    return hardware.robot.empty() ? sim::load_model_file(sim::default_model_path())
                                  : sim::planar_leg_model(load_robot(hardware.robot));
  }
  return names_robot_description(body) ? sim::planar_leg_model(load_robot(body)) : sim::load_model_file(body);
}

// The simulated body must have the legs the hardware description drives.
RobotConfig checked_against(RobotConfig config, const sim::PlanarLegModel& model) {
  if (static_cast<std::size_t>(config.leg_count()) != model.leg_count()) {
    throw InputError(fmt::format("{} describes {} legs; the simulated model has {}", config.source, config.leg_count(),
                                 model.leg_count()));
  }
  return config;
}

// Dry friction added to every hip gearbox and knee bearing: a robot that is stiffer than its model.
sim::PlanarLegModel with_extra_friction(sim::PlanarLegModel model, double extra_nm) {
  model.hip_motor.coulomb_friction_nm += extra_nm;
  model.knee_joint_friction_nm += extra_nm;
  return model;
}

// --switch-model-at N:BODY: from rollout N + 1 on, the robot is BODY (a worn spring, a swapped battery, another
// floor): the robot of a lifelong study changes under it, between two rollouts, as a real one would (issue 33).
struct BodySwitch {
  int after_rollouts = 0;
  std::string body;
  sim::PlanarLegModel model;
};

BodySwitch parse_body_switch(const std::string& text) {
  const std::size_t colon = text.find(':');
  BodySwitch out;
  std::size_t used = 0;
  try {
    out.after_rollouts = colon == std::string::npos ? -1 : std::stoi(text.substr(0, colon), &used);
  } catch (const std::exception&) {
    out.after_rollouts = -1;
  }
  if (colon == std::string::npos || used != colon || out.after_rollouts < 0) {
    throw InputError(fmt::format("--switch-model-at '{}': expected N:BODY, N >= 0 the rollouts run on the body before", text));
  }
  out.body = text.substr(colon + 1);
  if (out.body.empty()) throw InputError(fmt::format("--switch-model-at '{}': no body after the colon", text));
  return out;
}

// The simulation steps per control period: the body's physics rate must be a multiple of the robot's.
int steps_per_control(const sim::PlanarLegModel& model, const RobotConfig& config, const std::string& body) {
  const double ratio = model.physics_rate_hz / config.control_rate_hz;
  const int steps = static_cast<int>(std::lround(ratio));
  if (steps < 1 || std::abs(ratio - steps) > 1e-9) {
    throw InputError(fmt::format("{}: the model's physics rate {} Hz must be a multiple of the robot's control rate {} Hz",
                                 body, model.physics_rate_hz, config.control_rate_hz));
  }
  return steps;
}

class Emulator {
 public:
  explicit Emulator(const Options& o)
      : options_(o),
        hardware_(load_robot_config(o.robot_path)),
        model_(with_extra_friction(simulated_body(o.model_path, hardware_), o.extra_friction_nm)),
        terrain_(sim::TerrainSpec::parse(o.terrain)),
        config_(checked_against(hardware_, model_)),
        bus_(can::open_can_bus(o.can_uri, can::BusRole::kDevice)),
        device_(config_, *bus_, o.imperfections) {
    steps_per_control_ = steps_per_control(model_, config_, body_name());
    // Every switch's body is read and checked now: a bad one exits 2 before the bus carries a rollout.
    for (const std::string& text : o.body_switches) {
      BodySwitch next = parse_body_switch(text);
      next.model = with_extra_friction(simulated_body(next.body, hardware_), o.extra_friction_nm);
      (void)checked_against(hardware_, next.model);
      (void)steps_per_control(next.model, config_, next.body);
      switches_.push_back(std::move(next));
    }
    std::stable_sort(switches_.begin(), switches_.end(),
                     [](const BodySwitch& a, const BodySwitch& b) { return a.after_rollouts < b.after_rollouts; });
    reset_world();
  }

  int run() {
    std::fprintf(stderr, "emulator: %s (%zu legs, %.2f kg) on %s, %s, terrain %s\n", body_name().c_str(),
                 model_.leg_count(), model_.total_mass_kg(), options_.can_uri.c_str(),
                 options_.lockstep ? "lockstep" : "real time", terrain_.describe().c_str());
    return options_.lockstep ? run_lockstep() : run_realtime();
  }

 private:
  std::string body_name() const {
    if (!options_.model_path.empty()) return options_.model_path;
    return hardware_.robot.empty() ? sim::default_model_path() : "robot " + hardware_.robot;
  }

  // Before rollout rollouts_ + 1 starts: the last switch due by now (several at one N: the last given wins).
  void switch_body_if_due() {
    while (next_switch_ < switches_.size() && switches_[next_switch_].after_rollouts <= rollouts_) {
      const BodySwitch& due = switches_[next_switch_++];
      model_ = due.model;
      steps_per_control_ = steps_per_control(model_, config_, due.body);
      std::fprintf(stderr, "emulator: after %d rollouts the body is now %s (%zu legs, %.2f kg)\n", rollouts_,
                   due.body.c_str(), model_.leg_count(), model_.total_mass_kg());
    }
  }

  void reset_world() {
    plant_ = std::make_unique<sim::OdePlant>(model_, terrain_, options_.seed);
    device_.update(plant_->state(), 0.0);
  }

  bool any_enabled() const {
    for (int j = 0; j < device_.joint_count(); ++j) {
      if (device_.enabled(j)) return true;
    }
    return false;
  }

  bool all_enabled() const {
    for (int j = 0; j < device_.joint_count(); ++j) {
      if (!device_.enabled(j)) return false;
    }
    return true;
  }

  // Every motor off, or told kp = 0 and no feed-forward torque (the agent's safe state: it only damps).
  bool every_motor_safe() const {
    for (int j = 0; j < device_.joint_count(); ++j) {
      const MotorCommand& c = device_.last_command(j);
      if (device_.enabled(j) && (c.kp_nm_per_rad != 0.0 || c.torque_nm != 0.0)) return false;
    }
    return true;
  }

  // The moments the robot stops being driven and is switched off, in Unix time (to the microsecond):
  // tests compare them with the time an emergency stop was sent (tests/robot/test_agent_estop.sh).
  void log_safety_transitions() {
    const bool safe = every_motor_safe(), off = !any_enabled();
    const double unix_s = std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
    if (safe && !was_safe_) std::fprintf(stderr, "emulator: every motor safe (kp = 0, no torque, or off) at unix %.6f s\n", unix_s);
    if (off && !was_off_) std::fprintf(stderr, "emulator: every motor off at unix %.6f s\n", unix_s);
    was_safe_ = safe;
    was_off_ = off;
  }

  // Applies one received frame's consequences that do not depend on the stepping mode.
  RobotDevice::Received take(std::chrono::nanoseconds timeout) {
    const bool was_enabled = any_enabled();
    const RobotDevice::Received got = device_.receive(timeout);
    if (got.event == RobotDevice::Event::kEnable && !was_enabled) {
      switch_body_if_due();
      reset_world();
      ++rollouts_;
      std::fprintf(stderr, "emulator: motors enabled, rollout %d starts on a fresh world\n", rollouts_);
    }
    if (got.event != RobotDevice::Event::kNone) log_safety_transitions();
    return got;
  }

  // The drivers' command watchdog: motors that stopped hearing the controller go to the safe state on
  // their own, as real drivers do, and the moment is logged (Unix time, for the tests).
  void enforce_driver_watchdog(double timeout_ms) {
    const int made_safe = device_.enforce_command_timeout(monotonic_ns(), std::llround(timeout_ms * 1e6));
    if (made_safe == 0) return;
    const double unix_s = std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
    std::fprintf(stderr, "emulator: driver watchdog: %d motor(s) without a command for %.0f ms, to the safe state at unix %.6f s\n",
                 made_safe, timeout_ms, unix_s);
    log_safety_transitions();
  }

  void step_physics() {
    const double dt = plant_->time_step_s();
    plant_->command(device_.joint_commands());
    plant_->advance(dt);
    device_.update(plant_->state(), dt);
  }

  int run_lockstep() {
    while (!g_stop) {
      const auto got = take(std::chrono::milliseconds(50));
      if (got.event == RobotDevice::Event::kQuery && got.reply_owed) {
        device_.reply(got.joint);  // a request after this period's step (ODrive's Get_Iq): answered at once
      } else if (got.event == RobotDevice::Event::kEnable) {
        device_.reply(got.joint);
        if (all_enabled()) device_.send_sensors();  // once the robot is ready, not once per motor
      } else if (got.event == RobotDevice::Event::kCommand && device_.all_commanded()) {
        for (int k = 0; k < steps_per_control_; ++k) step_physics();
        device_.reply_all();
        device_.send_sensors();
        device_.clear_commanded();
      }
      // Lockstep waits for the controller by design, and its agent allows 0.5 s between replies on a
      // loaded machine: the drivers' watchdog waits at least a second here.
      enforce_driver_watchdog(std::max(options_.driver_timeout_ms, 1000.0));
      device_.flush();
    }
    return kExitOk;
  }

  int run_realtime() {
    // Like the robot's own drivers, the twin must keep time: ask for the same real-time treatment.
    if (const RealtimeSetup rt = enter_realtime(70); !rt.warning.empty()) std::fprintf(stderr, "emulator: %s\n", rt.warning.c_str());
    const double dt = plant_->time_step_s();
    PeriodicTimer timer(std::llround(dt * 1e9));
    timer.start();
    long step = 0;
    while (!g_stop) {
      // Until the next physics step: answer every command at once with the latest state.
      while (true) {
        const std::int64_t left = to_ns(timer.deadline()) - monotonic_ns();
        if (left <= 0) break;
        const auto got = take(std::chrono::nanoseconds(left));
        if (got.reply_owed) device_.reply(got.joint);  // each protocol's twin says what it answers
        device_.flush();
      }
      enforce_driver_watchdog(options_.driver_timeout_ms);
      bool passed = false;
      timer.wait(passed);
      if (any_enabled()) step_physics();  // all motors off: the robot hangs in its rig
      if (++step % steps_per_control_ == 0) device_.send_sensors();
      device_.flush();
    }
    return kExitOk;
  }

  Options options_;
  RobotConfig hardware_;  // as read; config_ is it once checked against the body
  sim::PlanarLegModel model_;
  sim::TerrainSpec terrain_;
  RobotConfig config_;
  std::unique_ptr<can::CanBus> bus_;
  RobotDevice device_;
  std::unique_ptr<sim::OdePlant> plant_;
  int steps_per_control_ = 2;
  bool was_safe_ = true;  // the robot starts off, hanging in its rig
  bool was_off_ = true;
  int rollouts_ = 0;
  std::vector<BodySwitch> switches_;  // by after_rollouts
  std::size_t next_switch_ = 0;
};

}  // namespace
}  // namespace cpgmatch::robot

int main(int argc, char** argv) {
  using namespace cpgmatch;
  using namespace cpgmatch::robot;
  CLI::App app{"cpgmatch-robot-emulator: a robot in ODE behind its CAN motor and sensor protocol"};
  Options o;
  app.add_option("--can", o.can_uri, "bus URI: udp:HOST:PORT (binds it), socketcan:IFACE or virtual:NAME")->required();
  app.add_option("--model", o.model_path,
                 "the simulated body: a robot description (shipped name, folder, robot.yaml) or a model file "
                 "(default: the robot the hardware file names, else configs/model/morti.yaml)");
  app.add_option("--robot", o.robot_path, "hardware description the agent drives (default: configs/robot/morti.yaml)");
  app.add_option("--switch-model-at", o.body_switches,
                 "N:BODY: from rollout N+1 on, simulate BODY instead (as --model; repeatable): the robot changes mid-study");
  app.add_option("--terrain", o.terrain, "flat | step:H@D | rough:A | shift:H@T")->capture_default_str();
  app.add_option("--seed", o.seed, "seed of the world (rough terrain) and of the imperfections")->capture_default_str();
  app.add_flag("--lockstep", o.lockstep, "step one control period whenever every motor was commanded (no wall clock)");
  app.add_option("--position-noise", o.imperfections.position_noise_rad, "Gaussian noise on motor positions, rad")->check(CLI::Range(0.0, 1.0));
  app.add_option("--foot-noise", o.imperfections.foot_noise_n, "Gaussian noise on foot forces, N")->check(CLI::Range(0.0, 100.0));
  app.add_option("--contact-dropout", o.imperfections.contact_dropout, "probability a foot frame reads 0 N")->check(CLI::Range(0.0, 1.0));
  app.add_option("--reply-dropout", o.imperfections.reply_dropout, "probability a motor reply is lost")->check(CLI::Range(0.0, 1.0));
  app.add_option("--latency-ms", o.latency_ms, "delay of every frame the robot sends, ms")->check(CLI::Range(0.0, 100.0));
  app.add_option("--backlash", o.imperfections.backlash_rad, "gear play between encoder and joint, rad (total)")->check(CLI::Range(0.0, 0.5));
  app.add_option("--extra-friction", o.extra_friction_nm, "dry friction added to every hip gearbox and knee bearing, N m")
      ->check(CLI::Range(0.0, 5.0));
  app.add_option("--driver-timeout-ms", o.driver_timeout_ms,
                 "the motor drivers' command watchdog: an enabled motor without a command this long goes to the "
                 "safe state by itself, ms (lockstep: at least 1000)")
      ->check(CLI::Range(1.0, 10000.0))
      ->capture_default_str();
  runtime::add_version_flag(app, "cpgmatch-robot-emulator");
  runtime::add_man_page_flag(app, "cpgmatch-robot-emulator");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? kExitOk : kExitBadInput;
  }
  return run_reporting_errors([&] {
    runtime::export_config_dir();  // the default model and robot YAML of an installed prefix, too
    if (o.robot_path.empty()) o.robot_path = default_robot_config_path();
    o.imperfections.latency_s = o.latency_ms / 1000.0;
    o.imperfections.seed = o.seed + 1;
    std::signal(SIGINT, on_signal);
    std::signal(SIGTERM, on_signal);
    Emulator emulator(o);
    return emulator.run();
  });
}
