// Synthetic "hardware" traces for the calibration tests: rollouts of a shipped model (the robot), with the
// sensor noise a robot adds. Shared by the calibration test files.
#pragma once

#include <cmath>
#include <random>
#include <string>

#include "cpgmatch/calibration/measured_trace.hpp"
#include "cpgmatch/sim/ode_plant.hpp"
#include "cpgmatch/sim/sim_rollout.hpp"

namespace cpgmatch::calibration::synthetic {

inline CpgParameters matched_trot() { return load_parameters(sim::config_dir() + "/params/matched-trot.yaml"); }
inline RolloutSettings settings() { return load_rollout_settings(sim::default_rollout_settings_path()); }
inline sim::PlanarLegModel model(const std::string& name) {
  return sim::load_model_file(sim::config_dir() + "/model/" + name + ".yaml");
}

// A matched trot of `seconds` (1 s entrainment) on model `m`.
inline sim::SimRolloutJob job(const sim::PlanarLegModel& m, std::uint64_t seed, double seconds) {
  sim::SimRolloutJob j;
  j.params = matched_trot();
  j.settings = settings();
  j.settings.entrain_s = 1.0;
  j.settings.eval_s = seconds - 1.0;
  j.model = m;
  j.seed = seed;
  return j;
}

inline MeasuredTrace recorded(const sim::PlanarLegModel& m, std::uint64_t seed, double seconds) {
  MeasuredTrace trace;
  trace.source = "seed " + std::to_string(seed);
  sim::run_sim_rollout(job(m, seed, seconds), record_trace(trace));
  return trace;
}

// What a robot's sensors add: encoder and IMU noise (the emulator's --position-noise order), FootTile noise
// (configs/rollout.yaml's 0.3 N), and the CAN protocol's quantisation of joint positions (0.38 mrad).
inline void add_sensor_noise(MeasuredTrace& trace, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> joint(0.0, 0.005), pitch(0.0, 0.003), speed(0.0, 0.02), force(0.0, 0.3);
  const auto quantise = [](double rad) { return std::round(rad / 3.8e-4) * 3.8e-4; };
  for (auto& tick : trace.ticks) {
    tick.pitch_rad += pitch(rng);
    tick.vx_mps += speed(rng);
    for (auto& leg : tick.legs) {
      leg.hip_rad = quantise(leg.hip_rad + joint(rng));
      leg.knee_rad = quantise(leg.knee_rad + joint(rng));
      leg.foot_force_n += force(rng);
    }
  }
}

// A body behind a bus that carries joint targets in steps of `step_rad` (the CAN protocol's 16-bit targets):
// the robot executes rounded commands while the trace records the controller's own, so a replay of the
// trace's commands is not exactly what the body did. This is the kind of unmodelled difference that made
// the emulator's replays drift (docs/calibration.md).
class QuantisedCommandPlant final : public Plant {
 public:
  QuantisedCommandPlant(Plant& body, double step_rad) : body_(body), step_(step_rad) {}
  void command(const PerLeg<JointCommand>& commands) override {
    PerLeg<JointCommand> rounded = commands;
    for (auto& c : rounded) {
      c.hip_angle_rad = std::round(c.hip_angle_rad / step_) * step_;
      c.knee_flexion_rad = std::round(c.knee_flexion_rad / step_) * step_;
    }
    body_.command(rounded);
  }
  void advance(double dt_s) override { body_.advance(dt_s); }
  PlantState state() const override { return body_.state(); }
  double time_step_s() const override { return body_.time_step_s(); }

 private:
  Plant& body_;
  double step_;
};

inline MeasuredTrace recorded_behind_bus(const sim::PlanarLegModel& m, std::uint64_t seed, double seconds, double step_rad) {
  const sim::SimRolloutJob j = job(m, seed, seconds);
  sim::OdePlant body(j.model, j.terrain, j.seed);
  QuantisedCommandPlant plant(body, step_rad);
  MeasuredTrace trace;
  trace.source = "seed " + std::to_string(seed) + " behind a bus";
  run_rollout(plant, j.params, j.settings, j.seed, record_trace(trace));
  return trace;
}

}  // namespace cpgmatch::calibration::synthetic
