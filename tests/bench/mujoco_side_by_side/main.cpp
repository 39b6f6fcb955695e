// cpgmatch-bench-mujoco: the same robot and the same gait in MuJoCo and in cpgmatch's ODE plant (issue 32).
//
// Morti's URDF is loaded by MuJoCo's own URDF import and held in the sagittal plane (mujoco_plant.hpp); the
// gait is cpgmatch's CpgController through run_rollout in both engines, so only the physics differs. For
// standing (zero commands) and each of the robot's presets it prints simulated seconds per wall second (a
// rollout's wall time and CPU time, plant construction included, median of --repeats) and the gait's speed, duty factors
// and cost in both. Usage: cpgmatch-bench-mujoco [--robot morti] [--repeats 3] [--solver newton|cg|pgs] [--iterations N] [--json]
#include <algorithm>
#include <chrono>
#include <ctime>
#include <cstdlib>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "cpgmatch/errors.hpp"
#include "cpgmatch/robot_description_loader.hpp"
#include "cpgmatch/rollout.hpp"
#include "cpgmatch/sim/ode_plant.hpp"
#include "cpgmatch/sim/planar_leg_model.hpp"
#include "cpgmatch/sim/sim_rollout.hpp"
#include "mujoco_plant.hpp"

namespace {

using namespace cpgmatch;
using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }
// This process's CPU time: what a rollout costs a core, whatever else the machine runs (it is shared).
double cpu_s() { return static_cast<double>(std::clock()) / CLOCKS_PER_SEC; }

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v[v.size() / 2];
}

// Duty factor as the feet report it: the fraction of control ticks in the evaluation window with the
// (debounced) contact on, averaged over the legs of a group.
struct DutyMeter {
  double from_s;
  std::vector<std::string> groups;
  std::vector<double> on, ticks;
  TraceSink sink() {
    return [this](const TraceSample& s) {
      if (s.time_s < from_s) return;
      for (std::size_t i = 0; i < groups.size(); ++i) {
        on[i] += (*s.contacts)[i] ? 1.0 : 0.0;
        ticks[i] += 1.0;
      }
    };
  }
  double group(const std::string& g) const {
    double sum = 0.0, n = 0.0;
    for (std::size_t i = 0; i < groups.size(); ++i) {
      if (groups[i] == g && ticks[i] > 0.0) {
        sum += on[i] / ticks[i];
        n += 1.0;
      }
    }
    return n > 0.0 ? sum / n : -1.0;
  }
};

// Forwards to a plant and clocks the time spent in its advance(): the physics engine's share of a rollout
// (the rest is the controller, contact sensing, cost and energy bookkeeping, the same code in both engines).
class TimedPlant : public Plant {
 public:
  explicit TimedPlant(Plant& inner) : inner_(inner) {}
  void command(const PerLeg<JointCommand>& c) override { inner_.command(c); }
  void advance(double dt_s) override {
    const auto t0 = Clock::now();
    inner_.advance(dt_s);
    physics_s += seconds_since(t0);
  }
  PlantState state() const override { return inner_.state(); }
  double time_step_s() const override { return inner_.time_step_s(); }
  std::optional<EnergyModel> energy_model() const override { return inner_.energy_model(); }
  double physics_s = 0.0;

 private:
  Plant& inner_;
};

struct EngineRun {
  RolloutResult result;
  double physics_s = 0.0;  // wall time inside the engine's step, first repeat
  double duty_front = -1.0, duty_hind = -1.0;
  double wall_s = 0.0;  // median over repeats, plant construction included
  double cpu_s = 0.0;   // the same in CPU time
};

struct Setup {
  RobotDescription robot;
  sim::SimRolloutJob job;
};

// Repeat 0 runs on a TimedPlant with the duty meter; the others time whole rollouts as a user runs them
// (the median of those is the wall time; of repeat 0 alone when there is one).
template <typename MakePlant, typename RunOnce>
EngineRun measure(const Setup& setup, int repeats, MakePlant make_plant, RunOnce run_once) {
  EngineRun out;
  DutyMeter meter{setup.job.settings.entrain_s, {}, {}, {}};
  for (const auto& leg : setup.robot.legs) meter.groups.push_back(leg.group);
  meter.on.assign(meter.groups.size(), 0.0);
  meter.ticks.assign(meter.groups.size(), 0.0);
  std::vector<double> walls, cpus;
  {
    const double c0 = cpu_s();
    const auto t0 = Clock::now();
    auto plant = make_plant();
    TimedPlant timed(*plant);
    out.result = run_rollout(timed, setup.job.params, setup.job.settings, setup.job.seed, meter.sink());
    out.physics_s = timed.physics_s;
    if (repeats == 1) {
      walls.push_back(seconds_since(t0));
      cpus.push_back(cpu_s() - c0);
    }
  }
  for (int r = 1; r < repeats; ++r) {
    const double c0 = cpu_s();
    const auto t0 = Clock::now();
    run_once();
    walls.push_back(seconds_since(t0));
    cpus.push_back(cpu_s() - c0);
  }
  out.duty_front = meter.group("front");
  out.duty_hind = meter.group("hind");
  out.wall_s = median(walls);
  out.cpu_s = median(cpus);
  return out;
}

// Standing: zero joint commands (the standing pose) for `seconds`; where the trunk ends up and how fast.
struct Standing {
  double height_m, pitch_rad, x_m, wall_s;
};
Standing stand(Plant& plant, double seconds) {
  const auto t0 = Clock::now();
  plant.command(PerLeg<JointCommand>(plant.state().legs.size()));
  const long steps = std::lround(seconds / plant.time_step_s());
  for (long i = 0; i < steps; ++i) plant.advance(plant.time_step_s());
  const PlantState s = plant.state();
  return {s.trunk.height_m, s.trunk.pitch_rad, s.trunk.x_m, seconds_since(t0)};
}

int run(int argc, char** argv) {
  std::string robot_name = "morti";
  int repeats = 3;
  bool json = false;
  bench::MujocoSolver solver;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--robot" && i + 1 < argc) robot_name = argv[++i];
    else if (a == "--repeats" && i + 1 < argc) repeats = std::max(1, std::atoi(argv[++i]));
    else if (a == "--json") json = true;
    else if (a == "--solver" && i + 1 < argc) solver.solver = argv[++i];
    else if (a == "--iterations" && i + 1 < argc) solver.iterations = std::max(1, std::atoi(argv[++i]));
    else throw InputError("usage: cpgmatch-bench-mujoco [--robot NAME] [--repeats N] [--solver newton|cg|pgs] [--iterations N] [--json]; unknown '" + a + "'");
  }
  Setup setup;
  setup.robot = load_robot(robot_name);
  setup.job.model = sim::planar_leg_model(setup.robot);
  if (setup.job.model.knee_drive != sim::PlanarLegModel::KneeDrive::kSeriesElastic) {
    throw InputError("the MuJoCo bench mirrors the series-elastic knee only");
  }
  setup.job.settings = load_rollout_settings(sim::default_rollout_settings_path());
  apply_robot_legs(setup.job.settings.controller, setup.robot);
  const double sim_s = setup.job.settings.entrain_s + setup.job.settings.eval_s;

  {
    sim::OdePlant ode(setup.job.model, setup.job.terrain, 0);
    const auto t0 = Clock::now();
    bench::MujocoPlant mj(setup.robot, setup.job.model, solver);
    const double mj_build = seconds_since(t0);
    const Standing so = stand(ode, 5.0), sm = stand(mj, 5.0);
    if (json) {
      std::cout << fmt::format(R"({{"case":"standing","sim_s":5.0,"ode":{{"height_m":{:.5f},"pitch_rad":{:.5f},"x_m":{:.5f},"sim_per_wall":{:.1f}}},"mujoco":{{"height_m":{:.5f},"pitch_rad":{:.5f},"x_m":{:.5f},"sim_per_wall":{:.1f},"build_s":{:.4f}}}}})",
                               so.height_m, so.pitch_rad, so.x_m, 5.0 / so.wall_s, sm.height_m, sm.pitch_rad, sm.x_m,
                               5.0 / sm.wall_s, mj_build)
                << "\n";
    } else {
      fmt::print("standing 5 s (zero commands)   ODE: height {:.4f} m pitch {:+.4f} rad x {:+.4f} m, {:.0f} sim s/wall s\n",
                 so.height_m, so.pitch_rad, so.x_m, 5.0 / so.wall_s);
      fmt::print("                            MuJoCo: height {:.4f} m pitch {:+.4f} rad x {:+.4f} m, {:.0f} sim s/wall s "
                 "(URDF import + MJCF compile {:.1f} ms)\n",
                 sm.height_m, sm.pitch_rad, sm.x_m, 5.0 / sm.wall_s, 1e3 * mj_build);
    }
  }

  if (!json) {
    fmt::print("\n{} s rollouts (entrain {} s + eval {} s), wall = median of {}, plant construction included\n", sim_s,
               setup.job.settings.entrain_s, setup.job.settings.eval_s, repeats);
    fmt::print("{:<14} {:<7} {:>9} {:>8} {:>8} {:>8} {:>7} {:>6} {:>11} {:>14} {:>11}\n", "preset", "engine", "cost", "speed",
               "DF front", "DF hind", "fell", "wall s", "sim s/wall", "physics s/wall", "sim s/cpu s");
  }
  for (const auto& [name, values] : setup.robot.presets) {
    Setup s = setup;
    for (const auto& [param, value] : values) set_parameter(s.job.params, param, value, "preset " + name);
    // The ODE rollout exactly as run_sim_rollout runs it (an OdePlant, then run_rollout).
    const EngineRun ode = measure(
        s, repeats, [&] { return std::make_unique<sim::OdePlant>(s.job.model, s.job.terrain, s.job.seed); },
        [&] { return sim::run_sim_rollout(s.job); });
    const EngineRun mj = measure(
        s, repeats, [&] { return std::make_unique<bench::MujocoPlant>(s.robot, s.job.model, solver); },
        [&] {
          bench::MujocoPlant plant(s.robot, s.job.model, solver);
          return run_rollout(plant, s.job.params, s.job.settings, s.job.seed);
        });
    for (const auto& [engine, e] : {std::pair<const char*, const EngineRun&>{"ode", ode}, {"mujoco", mj}}) {
      const RolloutResult& r = e.result;
      if (json) {
        std::cout << fmt::format(R"({{"case":"{}","engine":"{}","outcome":"{}","cost":{:.6f},"speed_mps":{:.5f},"duty_front":{:.4f},"duty_hind":{:.4f},"fell":{},"fall_time_s":{:.3f},"sim_s":{:.3f},"wall_s":{:.5f},"sim_per_wall":{:.2f},"cpu_s":{:.5f},"sim_per_cpu":{:.2f},"physics_s":{:.5f},"physics_sim_per_wall":{:.1f},"terms":{{"feedback":{:.4f},"distance":{:.4f},"pitch":{:.4f},"contact":{:.4f},"periodicity":{:.4f}}},"cot":{:.4f}}})",
                                 name, engine, to_string(r.outcome), r.cost, r.breakdown.mean_speed_mps, e.duty_front,
                                 e.duty_hind, r.fell ? "true" : "false", r.fall_time_s, r.sim_time_s, e.wall_s,
                                 r.sim_time_s / e.wall_s, e.cpu_s, r.sim_time_s / e.cpu_s, e.physics_s,
                                 r.sim_time_s / e.physics_s,
                                 r.breakdown.terms.feedback, r.breakdown.terms.distance, r.breakdown.terms.pitch,
                                 r.breakdown.terms.contact, r.breakdown.terms.periodicity,
                                 r.energy.electrical_cost_of_transport)
                  << "\n";
      } else {
        fmt::print("{:<14} {:<7} {:>9.4f} {:>8.4f} {:>8.3f} {:>8.3f} {:>7} {:>6.3f} {:>11.1f} {:>14.1f} {:>11.1f}\n", name, engine,
                   r.cost, r.breakdown.mean_speed_mps, e.duty_front, e.duty_hind,
                   r.fell ? fmt::format("{:.2f}s", r.fall_time_s) : std::string("no"), e.wall_s,
                   r.sim_time_s / e.wall_s, r.sim_time_s / e.physics_s, r.sim_time_s / e.cpu_s);
        fmt::print("{:<22} terms: feedback {:.3f} distance {:.3f} pitch {:.3f} contact {:.3f} periodicity {:.3f}; "
                   "electrical CoT {:.3f}\n", "", r.breakdown.terms.feedback, r.breakdown.terms.distance,
                   r.breakdown.terms.pitch, r.breakdown.terms.contact, r.breakdown.terms.periodicity,
                   r.energy.electrical_cost_of_transport);
      }
    }
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const cpgmatch::InputError& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 1;
  }
}
