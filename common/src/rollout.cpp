#include "cpgmatch/rollout.hpp"

#include <chrono>
#include <cmath>
#include <fstream>
#include <memory>
#include <numbers>
#include <optional>
#include <string>

#include <fmt/format.h>

#include "cpgmatch/errors.hpp"
#include "cpgmatch/yaml_reader.hpp"

namespace cpgmatch {
namespace {

int divider(double base_rate_hz, double rate_hz, const char* what) {
  const double ratio = base_rate_hz / rate_hz;
  const long rounded = std::lround(ratio);
  if (rounded < 1 || std::abs(ratio - rounded) > 1e-6) {
    throw InputError(fmt::format("{} rate {} Hz must divide the physics rate {} Hz", what, rate_hz, base_rate_hz));
  }
  return static_cast<int>(rounded);
}

bool finite_state(const PlantState& s) {
  return std::isfinite(s.trunk.x_m) && std::isfinite(s.trunk.height_m) && std::isfinite(s.trunk.pitch_rad) &&
         std::isfinite(s.trunk.roll_rad) && std::isfinite(s.trunk.lateral_m);
}

// Rates no 4-kg legged body reaches, falling included: a trunk tipping over under gravity turns at a few
// rad/s (sqrt(g / 0.28 m) ~ 6 rad/s from standing) and falls at under 3 m/s from its height; a foot strike
// jolts it far less. A state that moves faster than these between two control ticks is the integrator
// blowing up (an explicit damper too stiff for the step, say), not a gait: it must not be scored as a fall.
constexpr double kMaxPlausiblePitchRate_rad_s = 100.0;
constexpr double kMaxPlausibleTrunkSpeed_m_s = 30.0;

struct TimedTrunk {
  double time_s = -1.0;  // < 0: none yet
  TrunkState trunk;
};

// Why a state is not a physical one (non-finite, or reached from the previous tick impossibly fast).
std::optional<std::string> impossible_motion(const TimedTrunk& previous, const PlantState& s) {
  if (!finite_state(s)) {
    return fmt::format("non-finite trunk state (x {}, height {}, pitch {}, roll {}, lateral {})", s.trunk.x_m,
                       s.trunk.height_m, s.trunk.pitch_rad, s.trunk.roll_rad, s.trunk.lateral_m);
  }
  const double dt = s.time_s - previous.time_s;
  if (previous.time_s < 0.0 || !(dt > 0.0)) return std::nullopt;
  // A free robot's roll is held to the same bound as its pitch (0 on a rail).
  const double pitch_rate = std::max(std::abs(s.trunk.pitch_rad - previous.trunk.pitch_rad),
                                     std::abs(s.trunk.roll_rad - previous.trunk.roll_rad)) / dt;
  const double speed = std::hypot(s.trunk.x_m - previous.trunk.x_m, s.trunk.height_m - previous.trunk.height_m) / dt;
  if (pitch_rate > kMaxPlausiblePitchRate_rad_s) {
    return fmt::format("trunk pitch or roll moved {:.3f} rad in {:.1f} ms ({:.0f} rad/s; a body of this size turns at most a "
                       "few rad/s)",
                       pitch_rate * dt, dt * 1e3, pitch_rate);
  }
  if (speed > kMaxPlausibleTrunkSpeed_m_s) {
    return fmt::format("trunk moved {:.3f} m in {:.1f} ms ({:.0f} m/s)", speed * dt, dt * 1e3, speed);
  }
  return std::nullopt;
}

EnergySample energy_sample(const PlantState& s) {
  EnergySample e;
  e.time_s = s.time_s;
  e.hip = PerLeg<JointDrive>(s.legs.size());
  e.knee = PerLeg<JointDrive>(s.legs.size());
  for (std::size_t leg = 0; leg < s.legs.size(); ++leg) {
    e.hip[leg] = {s.legs[leg].hip_torque_nm, s.legs[leg].hip_speed_rad_s};
    e.knee[leg] = {s.legs[leg].knee_torque_nm, s.legs[leg].knee_motor_speed_rad_s};
  }
  return e;
}

}  // namespace

RolloutClock::RolloutClock(const Plant& plant, const RolloutSettings& settings) {
  const double physics_rate = 1.0 / plant.time_step_s();
  control_every_ = divider(physics_rate, settings.controller.control_rate_hz, "control");
  contact_every_ = divider(physics_rate, settings.contact_sensor.poll_rate_hz, "contact polling");
}

std::optional<PlantState> RolloutClock::sense(long step, const Plant& plant, ContactSensor& sensor,
                                              PerLeg<bool>& contacts) const {
  const bool poll = step % contact_every_ == 0;
  const bool control = step % control_every_ == 0;
  if (!poll && !control) return std::nullopt;
  PlantState state = plant.state();
  if (poll) {
    PerLeg<double> forces(state.legs.size());
    for (std::size_t leg = 0; leg < state.legs.size(); ++leg) forces[leg] = state.legs[leg].foot_normal_force_n;
    contacts = sensor.poll(state.time_s, forces);
  }
  if (!control) return std::nullopt;
  return state;
}

const char* to_string(PlantLifecycle lifecycle) {
  switch (lifecycle) {
    case PlantLifecycle::kInactive: return "inactive";
    case PlantLifecycle::kActive: return "active";
    case PlantLifecycle::kFault: return "in fault";
  }
  return "unknown";
}

const char* to_string(RolloutOutcome outcome) {
  switch (outcome) {
    case RolloutOutcome::kCompleted: return "completed";
    case RolloutOutcome::kFell: return "fell";
    case RolloutOutcome::kPlantFault: return "plant_fault";
    case RolloutOutcome::kDiverged: return "diverged";
  }
  return "unknown";
}

RolloutResult run_rollout(Plant& plant, const CpgParameters& params, const RolloutSettings& settings,
                          std::uint64_t seed, const TraceSink& trace) {
  const auto wall_start = std::chrono::steady_clock::now();
  // A plant never activated is a programming error; one that faulted after its activation (a stop that came
  // just before the loop) is a plant fault, which the loop's first tick reports as such.
  if (plant.lifecycle() == PlantLifecycle::kInactive) {
    throw InputError("run_rollout: the plant is inactive (activate() it first)");
  }
  validate(params);
  validate(settings.contact_sensor);
  const double dt = plant.time_step_s();
  const RolloutClock clock(plant, settings);
  const long total_steps = std::lround((settings.entrain_s + settings.eval_s) / dt);
  const long eval_start_step = std::lround(settings.entrain_s / dt);
  const double total_time = settings.entrain_s + settings.eval_s;

  CpgController controller(params, settings.controller);
  const std::size_t legs = controller.leg_count();
  if (plant.state().legs.size() != legs) {
    throw InputError(fmt::format("run_rollout: the plant has {} legs, the controller's robot {}", plant.state().legs.size(), legs));
  }
  ContactSensor sensor(settings.contact_sensor, seed, legs);
  CostRecorder recorder(settings.cost);
  EnergyRecorder energy(plant.energy_model());
  const auto eval_samples = static_cast<std::size_t>((total_steps - eval_start_step) / clock.control_every() + 2);
  recorder.reserve(eval_samples);
  energy.reserve(eval_samples);
  RolloutResult result;
  result.params = params;

  PerLeg<bool> contacts(legs, true);
  ControllerOutput output;
  bool commanded = false;  // output holds a command already sent to the plant
  double tracking_sq_sum = 0.0;
  long tracking_samples = 0;
  const double start_height = plant.state().trunk.height_m;
  double ended_at_s = -1.0;  // when a fall, a fault or a divergence ended the rollout early
  TimedTrunk previous_trunk;  // the trunk at the previous control tick
  for (long step = 0; step < total_steps; ++step) {
    if (const std::optional<PlantState> sensed = clock.sense(step, plant, sensor, contacts)) {
      const PlantState& state = *sensed;
      // A fault or a blow-up first: either makes the state meaningless, and neither is the gait's doing.
      if (auto fault = plant.fault()) {
        result.outcome = RolloutOutcome::kPlantFault;
        result.outcome_message = fmt::format("plant fault at t = {:.3f} s: {}", state.time_s, *fault);
        ended_at_s = state.time_s;
        break;
      }
      if (const auto why = impossible_motion(previous_trunk, state)) {
        result.outcome = RolloutOutcome::kDiverged;
        result.outcome_message = fmt::format("state diverged at t = {:.3f} s: {}", state.time_s, *why);
        ended_at_s = state.time_s;
        break;
      }
      previous_trunk = {state.time_s, state.trunk};
      // A trunk tilted past the limit either way has fallen: pitched (any robot) or rolled onto its side (a
      // robot free in 3D; a rail holds roll at 0).
      const bool fell = std::abs(state.trunk.pitch_rad) > settings.cost.fall_max_abs_pitch_rad ||
                        std::abs(state.trunk.roll_rad) > settings.cost.fall_max_abs_pitch_rad ||
                        state.trunk.height_m < std::min(settings.cost.fall_min_height_m, 0.5 * start_height);
      if (fell) {
        result.outcome = RolloutOutcome::kFell;
        result.fell = true;
        result.fall_time_s = state.time_s;
        ended_at_s = state.time_s;
        break;
      }
      if (commanded && state.time_s >= settings.controller.startup_ramp_s) {
        for (std::size_t leg = 0; leg < legs; ++leg) {
          if (output.commands[leg].hip_passive) continue;
          const double error = output.commands[leg].hip_angle_rad - state.legs[leg].hip_angle_rad;
          tracking_sq_sum += error * error;
          ++tracking_samples;
        }
      }
      output = controller.update(contacts);
      plant.command(output.commands);
      commanded = true;
      if (step >= eval_start_step) {
        CostSample sample;
        sample.time_s = state.time_s;
        sample.x_m = state.trunk.x_m;
        sample.pitch_rad = state.trunk.pitch_rad;
        sample.contact = contacts;
        sample.activity = output.activity;
        sample.abs_hip_torque_nm = PerLeg<double>(legs);
        sample.abs_knee_torque_nm = PerLeg<double>(legs);
        for (std::size_t leg = 0; leg < legs; ++leg) {
          sample.abs_hip_torque_nm[leg] = std::abs(state.legs[leg].hip_torque_nm);
          sample.abs_knee_torque_nm[leg] = std::abs(state.legs[leg].knee_torque_nm);
        }
        recorder.add(sample);
        energy.add(energy_sample(state));
      }
      if (trace) trace(TraceSample{state.time_s, &state, &output, &contacts});
    }
    plant.advance(dt);
  }

  result.sim_time_s = plant.state().time_s;
  if (tracking_samples > 0) result.hip_tracking_rms_rad = std::sqrt(tracking_sq_sum / tracking_samples);
  const double expected_pitch_hz = params.frequency * pitch_harmonic(controller.network().gait(), settings.controller.legs);
  result.breakdown = recorder.evaluate(params.frequency, expected_pitch_hz);
  result.energy = energy.evaluate(result.breakdown.distance_m, settings.cost.min_distance_m);
  // A fault or a divergence gets the fall cost as a placeholder: the optimizer never learns from it (its
  // outcome says so), but every report keeps a finite cost.
  result.cost = ended_at_s >= 0.0 ? recorder.fall_cost(ended_at_s, total_time, expected_pitch_hz)
                                  : result.breakdown.cost;
  result.breakdown.cost = result.cost;
  result.wall_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  return result;
}

CpgParameters load_parameters(const std::string& path, CpgParameters base) {
  return parse_parameters(YamlReader::from_file(path), base);
}

CpgParameters parse_parameters(const YamlReader& reader, CpgParameters base) {
  // Accept either a flat mapping or one nested under `params:`.
  const YamlReader map = reader.has("params") ? reader.child("params") : reader;
  map.for_each_number([&](const std::string& key, double value, const std::string& origin) {
    set_parameter(base, key, value, origin);
  });
  return base;
}

RolloutSettings load_rollout_settings(const std::string& path) {
  return parse_rollout_settings(YamlReader::from_file(path));
}

RolloutSettings parse_rollout_settings(const YamlReader& r) {
  r.reject_unknown_keys({"entrain_s", "eval_s", "controller", "contact_sensor", "cost"});
  RolloutSettings s;
  // The same ranges as `cpgmatch rollout --entrain/--eval` and a study's rollout block: an hour at most.
  s.entrain_s = r.get_double_in("entrain_s", s.entrain_s, 0.0, 3600.0);
  s.eval_s = r.get_double_in("eval_s", s.eval_s, 0.01, 3600.0);

  if (r.has("controller")) {
    const YamlReader c = r.child("controller");
    c.reject_unknown_keys({"gait", "coupling_gain_per_s", "control_rate_hz", "startup_ramp_s", "feedback"});
    auto& cc = s.controller;
    cc.gait = c.get_string("gait", cc.gait);
    try {
      (void)resolve_gait(cc);
    } catch (const InputError& e) {
      c.fail("gait", e.what());
    }
    cc.coupling_gain_per_s = c.get_double_in("coupling_gain_per_s", cc.coupling_gain_per_s, 0.0, 1000.0);
    // 10 Hz is too slow to shape a 1-Hz step; 10 kHz bounds what any motor bus could carry (a simulated
    // rollout also needs it to divide the physics rate, checked when it runs).
    cc.control_rate_hz = c.get_double_in("control_rate_hz", cc.control_rate_hz, 10.0, 10000.0);
    cc.startup_ramp_s = c.get_double_in("startup_ramp_s", cc.startup_ramp_s, 0.0, 60.0);
    // A phase error of four all-to-all coupled legs decays as exp(-8 pi K t); the CPG's explicit Euler
    // step (one control period) follows it without oscillating only while 8 pi K dt <= 1: K <= 20/s at
    // the paper's 500 Hz. Beyond, the phases ring, and above twice that they diverge.
    const double max_coupling = cc.control_rate_hz / (8.0 * std::numbers::pi);
    if (cc.coupling_gain_per_s > max_coupling) {
      c.fail("coupling_gain_per_s",
             fmt::format("must be <= control_rate_hz / (8 pi) = {:.3g} 1/s for a stable CPG step, got {}", max_coupling,
                         cc.coupling_gain_per_s));
    }
    if (c.has("feedback")) {
      const YamlReader f = c.child("feedback");
      f.reject_unknown_keys({"late_touchdown", "early_touchdown", "early_toeoff", "late_toeoff_deceleration",
                             "late_touchdown_phase_rate", "late_toeoff_phase_rate", "reflex_duration_s",
                             "reflex_knee_flexion_rad", "reflex_hip_passive", "etd_min_airborne_s",
                             "etd_min_knee_flexion_fraction", "late_touchdown_max_wait_s",
                             "eto_min_stance_fraction", "reflex_hip_passive_s",
                             "reflex_needs_girdle_support"});
      auto& fb = cc.feedback;
      fb.late_touchdown = f.get_bool("late_touchdown", fb.late_touchdown);
      fb.early_touchdown = f.get_bool("early_touchdown", fb.early_touchdown);
      fb.early_toeoff = f.get_bool("early_toeoff", fb.early_toeoff);
      fb.late_toeoff_deceleration = f.get_bool("late_toeoff_deceleration", fb.late_toeoff_deceleration);
      // Phase speed factors: 0 stops the phase, 1 is the feedforward speed.
      fb.late_touchdown_phase_rate =
          f.get_double_in("late_touchdown_phase_rate", fb.late_touchdown_phase_rate, 0.0, 1.0);
      fb.late_toeoff_phase_rate = f.get_double_in("late_toeoff_phase_rate", fb.late_toeoff_phase_rate, 0.0, 1.0);
      // A reflex is part of one swing: at most 1 s (a whole step at the space's lowest frequency is longer).
      fb.reflex_duration_s = f.get_double_in("reflex_duration_s", fb.reflex_duration_s, 0.001, 1.0);
      // Added to the feedforward knee flexion; the knee's whole range (0.2-2.4 rad) bounds any sensible value.
      fb.reflex_knee_flexion_rad = f.get_double_in("reflex_knee_flexion_rad", fb.reflex_knee_flexion_rad, 0.0, 2.2);
      fb.reflex_hip_passive = f.get_bool("reflex_hip_passive", fb.reflex_hip_passive);
      fb.reflex_needs_girdle_support = f.get_bool("reflex_needs_girdle_support", fb.reflex_needs_girdle_support);
      fb.reflex_hip_passive_s = f.get_double_in("reflex_hip_passive_s", fb.reflex_hip_passive_s, 0.0, 1.0);
      fb.etd_min_airborne_s = f.get_double_in("etd_min_airborne_s", fb.etd_min_airborne_s, 0.0, 0.5);
      fb.etd_min_knee_flexion_fraction =
          f.get_double_in("etd_min_knee_flexion_fraction", fb.etd_min_knee_flexion_fraction, 0.0, 1.0);
      fb.eto_min_stance_fraction =
          f.get_double_in("eto_min_stance_fraction", fb.eto_min_stance_fraction, 0.0, 1.0);
      // Up to 10 s: a stance lasts well under that, so 10 is the paper's literal "until contact".
      fb.late_touchdown_max_wait_s =
          f.get_double_in("late_touchdown_max_wait_s", fb.late_touchdown_max_wait_s, 0.0, 10.0);
    }
  }
  if (r.has("contact_sensor")) {
    const YamlReader c = r.child("contact_sensor");
    c.reject_unknown_keys({"threshold_n", "release_threshold_n", "min_stable_s", "poll_rate_hz", "noise_std_n",
                           "latency_s"});
    auto& cs = s.contact_sensor;
    cs.threshold_n = c.get_double("threshold_n", cs.threshold_n);
    cs.release_threshold_n = c.get_double("release_threshold_n", cs.release_threshold_n);
    cs.min_stable_s = c.get_double("min_stable_s", cs.min_stable_s);
    cs.poll_rate_hz = c.get_double("poll_rate_hz", cs.poll_rate_hz);
    cs.noise_std_n = c.get_double("noise_std_n", cs.noise_std_n);
    cs.latency_s = c.get_double("latency_s", cs.latency_s);
    if (const auto problem = find_problem(cs)) c.fail(problem->field, problem->reason);
  }
  if (r.has("cost")) {
    const YamlReader c = r.child("cost");
    c.reject_unknown_keys({"weights", "min_distance_m", "fall_max_abs_pitch_rad", "fall_min_height_m",
                           "fall_cost_margin", "fall_cost_per_lost_fraction", "contact_cap"});
    auto& cc = s.cost;
    if (c.has("weights")) {
      const YamlReader w = c.child("weights");
      w.reject_unknown_keys({"feedback", "distance", "pitch", "contact", "periodicity"});
      // Non-negative: a negative weight would reward a term and break "a fall costs more than any non-fall".
      cc.weights.feedback = w.get_double_in("feedback", cc.weights.feedback, 0.0, 100.0);
      cc.weights.distance = w.get_double_in("distance", cc.weights.distance, 0.0, 100.0);
      cc.weights.pitch = w.get_double_in("pitch", cc.weights.pitch, 0.0, 100.0);
      cc.weights.contact = w.get_double_in("contact", cc.weights.contact, 0.0, 100.0);
      cc.weights.periodicity = w.get_double_in("periodicity", cc.weights.periodicity, 0.0, 100.0);
    }
    // 1 mm..100 m: the floor of x_body in J_distance = 1/x_body (J_distance then stays <= 1000).
    cc.min_distance_m = c.get_double_in("min_distance_m", cc.min_distance_m, 0.001, 100.0);
    // A fall is a trunk pitched beyond this (up to pi: upside down) or lower than this above the ground.
    cc.fall_max_abs_pitch_rad = c.get_double_in("fall_max_abs_pitch_rad", cc.fall_max_abs_pitch_rad, 0.05, 3.1416);
    cc.fall_min_height_m = c.get_double_in("fall_min_height_m", cc.fall_min_height_m, 0.0, 1.0);
    // The margin must be > 0: a fall must cost more than any non-fall.
    cc.fall_cost_margin = c.get_double_in("fall_cost_margin", cc.fall_cost_margin, 1e-6, 1000.0);
    cc.contact_cap = c.get_double_in("contact_cap", cc.contact_cap, 1e-6, 100.0);
    cc.fall_cost_per_lost_fraction =
        c.get_double_in("fall_cost_per_lost_fraction", cc.fall_cost_per_lost_fraction, 0.0, 1000.0);
  }
  return s;
}

TraceSink make_csv_trace(const std::string& path, const std::vector<std::string>& leg_names) {
  auto out = std::make_shared<std::ofstream>(path);
  if (!*out) throw InputError(fmt::format("{}: cannot open trace file for writing", path));
  *out << "time_s,x_m,height_m,pitch_rad,vx_mps";
  for (const auto& leg : leg_names) {
    *out << fmt::format(
        ",{0}_phase,{0}_hip_target_rad,{0}_hip_rad,{0}_knee_target_rad,{0}_knee_rad,{0}_hip_torque_nm,"
        "{0}_knee_torque_nm,{0}_foot_force_n,{0}_contact,{0}_ltd,{0}_etd,{0}_eto,{0}_lto",
        leg);
  }
  // The motors' output speeds (for their power, energy.hpp) after every leg's block, so older readers
  // that count columns still find theirs.
  for (const auto& leg : leg_names) *out << fmt::format(",{0}_hip_speed_rad_s,{0}_knee_motor_speed_rad_s", leg);
  // A free robot's roll, heading and sideways drift (0 on a rail), last for the same reason.
  *out << ",roll_rad,yaw_rad,lateral_m\n";
  return [out](const TraceSample& s) {
    const auto& st = *s.state;
    *out << fmt::format("{:.4f},{:.5f},{:.5f},{:.5f},{:.5f}", s.time_s, st.trunk.x_m, st.trunk.height_m,
                        st.trunk.pitch_rad, st.trunk.vx_mps);
    for (std::size_t leg = 0; leg < st.legs.size(); ++leg) {
      const auto& cmd = s.output->commands[leg];
      const auto& ls = st.legs[leg];
      const auto& a = s.output->activity[leg];
      *out << fmt::format(",{:.4f},{:.4f},{:.4f},{:.4f},{:.4f},{:.4f},{:.4f},{:.3f},{:d},{:d},{:d},{:d},{:d}",
                          s.output->phases[leg], cmd.hip_angle_rad, ls.hip_angle_rad, cmd.knee_flexion_rad,
                          ls.knee_flexion_rad, ls.hip_torque_nm, ls.knee_torque_nm, ls.foot_normal_force_n,
                          (*s.contacts)[leg], a.late_touchdown, a.early_touchdown, a.early_toeoff,
                          a.late_toeoff);
    }
    for (const auto& ls : st.legs) *out << fmt::format(",{:.4f},{:.4f}", ls.hip_speed_rad_s, ls.knee_motor_speed_rad_s);
    *out << fmt::format(",{:.5f},{:.5f},{:.5f}\n", st.trunk.roll_rad, st.trunk.yaw_rad, st.trunk.lateral_m);
  };
}

}  // namespace cpgmatch
