// What the motors spend over a rollout's evaluation window: positive mechanical work, Joule loss and
// electrical energy of a DC-motor model, cost of transport, and each joint's signed mean torque.
//
// Why beside eq. (1): the paper's normalised torque (sum of mean |torque| / speed) is dominated, in a
// series-elastic knee, by the steady torque of carrying the body; a motor that holds a load still does no
// mechanical work, yet pays for it in heat. These measures separate the two.
//
// The motor model. A brushed or brushless DC motor with a gearbox, seen at the joint, has a straight
// torque-speed line τ = τ_s (1 - ω/ω_0) at its supply voltage V: stall torque τ_s = k V / R and no-load
// speed ω_0 = V / k (k the torque constant at the joint, R the winding resistance; friction neglected).
// Its Joule loss at torque τ is I² R = τ² R / k², and from the two line values
//     R / k² = (V / τ_s) / (V / ω_0) ... = ω_0 / τ_s,
// so the Joule loss τ² ω_0 / τ_s needs neither V nor the gear ratio, only the two numbers the model gives
// (configs/model/morti.yaml: 4 N m and 12 rad/s for hip and knee; the paper, its notes and the model give
// no supply voltage, and none is needed). Electrical power drawn = mechanical power τ ω + Joule loss. A
// motor braking (τ ω < 0) could in principle return energy to the supply; hobby drivers dump it in a
// brake resistor or the bus capacitor rather than recover it, so a joint's electrical energy counts only
// what it draws: ∫ max(0, τ ω + τ² ω_0 / τ_s) dt. Driver (PWM, MOSFET) losses are left out.
//
// Cost of transport: energy / (m g d), m the robot's total mass, g gravity, d the distance walked in the
// window (floored at CostConfig::min_distance_m like J_distance and eq. 1, so a gait that stands still
// gets a large finite value, not infinity or a negative one).
//
// Units: joules, metres, seconds, newton-metres, radians per second.
#pragma once

#include <algorithm>
#include <cmath>
#include <optional>
#include <vector>

#include "cpgmatch/legs.hpp"

namespace cpgmatch {

// A joint's motor as its torque-speed line describes it, at the joint (after the gearbox).
struct DcMotorLine {
  double stall_torque_nm = 4.0;
  double no_load_speed_rad_s = 12.0;

  // R / k², W per (N m)²: the Joule loss of one newton-metre held for one second (see the header).
  double joule_coefficient() const { return no_load_speed_rad_s / stall_torque_nm; }
  // The largest torque the motor gives while turning at `speed` in the direction it pushes (motoring):
  // τ_s (1 - |ω| / ω_0), never below zero. Braking (torque against the motion) it holds up to τ_s.
  double available_torque_nm(double speed_rad_s) const {
    return stall_torque_nm * std::max(0.0, 1.0 - std::abs(speed_rad_s) / no_load_speed_rad_s);
  }
};

// What a plant knows about its body for energy: the two motors and the mass that is carried.
struct EnergyModel {
  DcMotorLine hip;
  DcMotorLine knee;
  double total_mass_kg = 4.0;
  double gravity_m_s2 = 9.81;
};

// One joint's motor over the evaluation window. NaN when not measured.
struct JointEnergy {
  double positive_work_j = std::nan("");       // ∫ max(0, τ ω) dt
  double joule_loss_j = std::nan("");          // ∫ τ² ω_0/τ_s dt (needs the motor model)
  double electrical_j = std::nan("");          // ∫ max(0, τ ω + τ² ω_0/τ_s) dt (needs the motor model)
  double signed_mean_torque_nm = std::nan("");  // mean of τ, keeping its sign
};

struct EnergyMeasures {
  PerLeg<JointEnergy> hip;   // one per leg
  PerLeg<JointEnergy> knee;
  double positive_work_j = std::nan("");  // sums over every hip and knee
  double joule_loss_j = std::nan("");
  double electrical_j = std::nan("");
  double hip_positive_work_j_per_m = std::nan("");   // every hip's positive work per metre walked
  double knee_positive_work_j_per_m = std::nan("");
  double positive_work_j_per_m = std::nan("");       // every hip and knee
  double mechanical_cost_of_transport = std::nan("");  // positive work / (m g d), dimensionless
  double electrical_cost_of_transport = std::nan("");  // electrical energy / (m g d)
  // Σ over joints of |signed mean τ| / mean speed, N m per (m/s): eq. 1 with the signed mean, which keeps
  // the torque a joint holds on average (the body's weight on a knee) and drops what oscillates about it.
  double signed_torque_per_speed = std::nan("");
};

// One joint's drive at one control tick: the torque its motor produces and the speed of the motor's output.
struct JointDrive {
  double torque_nm = 0.0;
  double speed_rad_s = 0.0;
};

struct EnergySample {
  double time_s = 0.0;
  PerLeg<JointDrive> hip;   // one per leg
  PerLeg<JointDrive> knee;
};

// Collects the evaluation window's drive samples and integrates them. Sample i's power is held until
// sample i+1 (the plant holds a command, and the samples come at the control rate), so the last sample
// closes the window and adds no energy; signed mean torques average every sample, like eq. 1's means.
class EnergyRecorder {
 public:
  // Without a model only what needs none is measured (positive work, signed torques); the rest is NaN.
  explicit EnergyRecorder(std::optional<EnergyModel> model) : model_(model) {}
  void reserve(std::size_t samples) { samples_.reserve(samples); }
  void add(const EnergySample& sample) { samples_.push_back(sample); }

  // `distance_m`: walked over the window, used floored at `min_distance_m`; `mean_speed_mps` likewise at
  // min_distance_m / window duration (the floors of J_distance and eq. 1).
  EnergyMeasures evaluate(double distance_m, double min_distance_m) const;

 private:
  std::optional<EnergyModel> model_;
  std::vector<EnergySample> samples_;
};

}  // namespace cpgmatch
