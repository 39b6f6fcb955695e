// The interface between the controller and a robot body, simulated or real.
//
// The same controller, contact sensing and cost run against any Plant: the ODE model in workers/ and the
// robot agent's motor bus later. A Plant holds the last joint command until a new one arrives, and
// advance() moves time forward (simulated physics steps, or waiting for the real-time clock).
// All values are SI: radians, metres, seconds, newtons, newton-metres.
#pragma once

#include <cmath>
#include <optional>
#include <string>

#include "cpgmatch/energy.hpp"
#include "cpgmatch/legs.hpp"

namespace cpgmatch {

struct JointCommand {
  double hip_angle_rad = 0.0;      // hip target relative to the plant's hip zero; + moves the foot forward
  double knee_flexion_rad = 0.0;   // knee flexion target on top of the standing knee angle
  bool hip_passive = false;        // hip motor produces no torque (impact mitigation)
};

struct LegState {
  double hip_angle_rad = 0.0;
  double knee_flexion_rad = 0.0;
  double hip_torque_nm = 0.0;      // torque the hip motor produced
  double knee_torque_nm = 0.0;     // torque the knee motor produced
  double foot_normal_force_n = 0.0;  // as the foot sensor reports it (a simulated FootTile may lag)
  // Speeds of the motors' outputs, for their power (torque x speed). The hip motor turns with the hip; the
  // knee motor drives the knee through its series spring, so its output (the spring's rest angle) turns
  // at its own speed, not the knee's. NaN from a plant that does not measure them.
  double hip_speed_rad_s = std::nan("");
  double knee_motor_speed_rad_s = std::nan("");
};

struct TrunkState {
  double x_m = 0.0;         // distance walked over the ground (treadmill: belt travel included)
  double height_m = 0.0;    // trunk centre height above the start ground level
  double pitch_rad = 0.0;   // + nose up
  double vx_mps = 0.0;      // forward speed over the ground
  // A robot free in 3D also rolls, turns and drifts sideways; on a rail or boom these stay 0.
  double roll_rad = 0.0;    // + left side up (about the forward axis)
  double yaw_rad = 0.0;     // + turned left (heading about the vertical)
  double lateral_m = 0.0;   // sideways from the start line, + left
};

struct PlantState {
  double time_s = 0.0;
  TrunkState trunk;
  PerLeg<LegState> legs;
};

// Where a plant is in its life, as ros2_control's hardware components are: inactive (its resources exist,
// nothing is driven), active (driven: a rollout may run on it), fault (tripped: safe, and it says why until
// the next activate() clears it; deactivate() switches it off). A simulation is active from its
// construction and faults never; a rollout on a plant in fault ends at once as a plant fault.
enum class PlantLifecycle { kInactive, kActive, kFault };
const char* to_string(PlantLifecycle lifecycle);

class Plant {
 public:
  virtual ~Plant() = default;
  // Makes the plant ready to be driven for `duration_s` seconds (a robot: motors enabled, every node heard,
  // joints ramped to standing); the reason when it cannot be (then it is left safe). Idempotent for a
  // simulation, which is always ready.
  virtual std::optional<std::string> activate(double /*duration_s*/) { return std::nullopt; }
  // Stops driving it: safe state, then off. Nothing for a simulation.
  virtual void deactivate() {}
  virtual PlantLifecycle lifecycle() const { return fault() ? PlantLifecycle::kFault : PlantLifecycle::kActive; }

  virtual void command(const PerLeg<JointCommand>& commands) = 0;
  virtual void advance(double dt_s) = 0;
  virtual PlantState state() const = 0;
  // The plant's own integration period (seconds); the rollout advances it in steps of this size.
  virtual double time_step_s() const = 0;
  // Why the body cannot go on (a motor watchdog, the bus, an emergency stop), or nothing while it is
  // healthy. A faulted plant's state says nothing about the gait: the rollout ends as a plant fault, not a
  // fall. A simulation has no such fault (a blow-up is seen as a non-finite state instead).
  virtual std::optional<std::string> fault() const { return std::nullopt; }
  // Its motors' torque-speed lines and the mass it carries, for the energy a rollout reports (energy.hpp);
  // nothing when the plant does not know them (then only what needs no model is measured).
  virtual std::optional<EnergyModel> energy_model() const { return std::nullopt; }
};

}  // namespace cpgmatch
