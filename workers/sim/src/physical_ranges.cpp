#include "cpgmatch/sim/physical_ranges.hpp"

#include <numbers>
#include <vector>

#include <fmt/format.h>

namespace cpgmatch::sim {

const PhysicalRange& range_for(Quantity q) {
  // Why each range: the bounds are ~3 orders of magnitude around what a legged robot of 1-50 kg has, tight
  // enough that ODE's solver (double precision, mass ratios, dt * stiffness) stays finite, wide enough for
  // any real robot of that size.
  static const PhysicalRange kMass{1e-3, 1e3, "a gram to a tonne; ODE steps a 1e308 kg or 1e-320 kg body into a "
                                              "non-finite quaternion and aborts"};
  static const PhysicalRange kLength{1e-3, 10.0, "a millimetre to ten metres; ODE's contact layer is 0.2 mm"};
  static const PhysicalRange kInertia{0.0, 10.0, "a gearmotor's reflected inertia about a leg joint is 1e-5..1e-2 kg m^2"};
  static const PhysicalRange kJointStiffness{1e-3, 1e4, "leg springs are 1-100 N m/rad; stiffer is a rigid joint"};
  static const PhysicalRange kJointDamping{0.0, 1e3, "leg joint damping is below 10 N m s/rad"};
  static const PhysicalRange kContactStiffness{1e2, 1e8, "ground contact is 1e4-1e6 N/m; 1e308 N/m runs as a "
                                                         "rigid contact and measures nothing"};
  static const PhysicalRange kContactDamping{1e-3, 1e6, "ground contact damping is 10-1e4 N s/m"};
  static const PhysicalRange kFriction{1e-3, 10.0, "Coulomb coefficients of real surfaces are 0.01-2"};
  static const PhysicalRange kTorque{0.0, 1e3, "a leg motor of a 1-50 kg robot gives 0.1-100 N m"};
  static const PhysicalRange kSpeed{1e-3, 1e3, "a geared leg motor turns at 1-100 rad/s"};
  static const PhysicalRange kGain{0.0, 1e4, "a position gain above 1e4 N m/rad is unstable at a 1 kHz step"};
  static const PhysicalRange kBandwidth{1e-2, 1e3, "a position loop faster than 1000/s is unstable at a 1 kHz step"};
  static const PhysicalRange kAngle{-std::numbers::pi, std::numbers::pi, "a joint angle lies within half a turn"};
  static const PhysicalRange kSensitivity{1e-3, 10.0, "a force sensor reports 0-2 times the force"};
  static const PhysicalRange kTimeConstant{0.0, 10.0, "a sensor lag of more than 10 s is longer than a gait cycle by 100 times"};
  static const PhysicalRange kPhysicsRate{100.0, 2e4, "below 100 Hz contacts explode; above 20 kHz a 60 s rollout "
                                                      "takes hours"};
  static const PhysicalRange kGravity{0.1, 100.0, "between a small moon's and 10 times Earth's"};
  switch (q) {
    case Quantity::kMass: return kMass;
    case Quantity::kLength: return kLength;
    case Quantity::kInertia: return kInertia;
    case Quantity::kJointStiffness: return kJointStiffness;
    case Quantity::kJointDamping: return kJointDamping;
    case Quantity::kContactStiffness: return kContactStiffness;
    case Quantity::kContactDamping: return kContactDamping;
    case Quantity::kFriction: return kFriction;
    case Quantity::kTorque: return kTorque;
    case Quantity::kSpeed: return kSpeed;
    case Quantity::kGain: return kGain;
    case Quantity::kBandwidth: return kBandwidth;
    case Quantity::kAngle: return kAngle;
    case Quantity::kSensitivity: return kSensitivity;
    case Quantity::kTimeConstant: return kTimeConstant;
    case Quantity::kPhysicsRate: return kPhysicsRate;
    case Quantity::kGravity: return kGravity;
  }
  return kMass;  // unreachable: every enumerator is handled above
}

namespace {

struct Entry {
  const char* section;
  const char* key;
  double value;
  Quantity quantity;
};

void add_motor(std::vector<Entry>& out, const char* section, const MotorModel& m) {
  out.push_back({section, "stall_torque_nm", m.stall_torque_nm, Quantity::kTorque});
  out.push_back({section, "no_load_speed_rad_s", m.no_load_speed_rad_s, Quantity::kSpeed});
  out.push_back({section, "kp_nm_per_rad", m.kp_nm_per_rad, Quantity::kGain});
  out.push_back({section, "kd_nm_s_per_rad", m.kd_nm_s_per_rad, Quantity::kJointDamping});
  out.push_back({section, "coulomb_friction_nm", m.coulomb_friction_nm, Quantity::kTorque});
  out.push_back({section, "viscous_friction_nm_s_per_rad", m.viscous_friction_nm_s_per_rad, Quantity::kJointDamping});
  out.push_back({section, "reflected_inertia_kg_m2", m.reflected_inertia_kg_m2, Quantity::kInertia});
}

}  // namespace

std::optional<RangeProblem> check_physical_ranges(const PlanarLegModel& m) {
  // In the model file's order, so the first problem is the first one a reader meets.
  std::vector<Entry> e = {
      {"trunk", "mass_kg", m.trunk_mass_kg, Quantity::kMass},
      {"trunk", "length_m", m.trunk_length_m, Quantity::kLength},
      {"trunk", "hip_spacing_m", m.hip_spacing_m, Quantity::kLength},
      {"trunk", "height_m", m.trunk_height_m, Quantity::kLength},
      {"trunk", "depth_m", m.trunk_depth_m, Quantity::kLength},
      {"femur", "length_m", m.femur.length_m, Quantity::kLength},
      {"femur", "mass_kg", m.femur.mass_kg, Quantity::kMass},
      {"shank", "length_m", m.shank.length_m, Quantity::kLength},
      {"shank", "mass_kg", m.shank.mass_kg, Quantity::kMass},
      {"foot", "length_m", m.foot.length_m, Quantity::kLength},
      {"foot", "mass_kg", m.foot.mass_kg, Quantity::kMass},
      {"leg", "toe_radius_m", m.toe_radius_m, Quantity::kLength},
      {"leg", "femur_mount_angle_rad", m.femur_mount_angle_rad, Quantity::kAngle},
      {"leg", "knee_stand_flexion_rad", m.knee_stand_flexion_rad, Quantity::kAngle},
      {"leg", "knee_min_flexion_rad", m.knee_min_flexion_rad, Quantity::kAngle},
      {"leg", "knee_max_flexion_rad", m.knee_max_flexion_rad, Quantity::kAngle},
      {"leg", "ankle_range_rad", m.ankle_range_rad, Quantity::kAngle},
      {"leg", "knee_joint_friction_nm", m.knee_joint_friction_nm, Quantity::kTorque},
      {"knee_spring", "stiffness_nm_per_rad", m.knee_spring.stiffness_nm_per_rad, Quantity::kJointStiffness},
      {"knee_spring", "damping_nm_s_per_rad", m.knee_spring.damping_nm_s_per_rad, Quantity::kJointDamping},
      {"biarticular_spring", "stiffness_nm_per_rad", m.biarticular_spring.stiffness_nm_per_rad, Quantity::kJointStiffness},
      {"biarticular_spring", "damping_nm_s_per_rad", m.biarticular_spring.damping_nm_s_per_rad, Quantity::kJointDamping},
  };
  add_motor(e, "hip_motor", m.hip_motor);
  e.push_back({"knee_motor", "stall_torque_nm", m.knee_motor.stall_torque_nm, Quantity::kTorque});
  e.push_back({"knee_motor", "no_load_speed_rad_s", m.knee_motor.no_load_speed_rad_s, Quantity::kSpeed});
  e.push_back({"knee_motor", "bandwidth_per_s", m.knee_motor_bandwidth_per_s, Quantity::kBandwidth});
  e.push_back({"contact", "friction", m.contact.friction, Quantity::kFriction});
  e.push_back({"contact", "stiffness_n_per_m", m.contact.stiffness_n_per_m, Quantity::kContactStiffness});
  e.push_back({"contact", "damping_n_s_per_m", m.contact.damping_n_s_per_m, Quantity::kContactDamping});
  e.push_back({"foot_sensor", "sensitivity", m.foot_sensor.sensitivity, Quantity::kSensitivity});
  e.push_back({"foot_sensor", "time_constant_s", m.foot_sensor.time_constant_s, Quantity::kTimeConstant});
  e.push_back({"simulation", "physics_rate_hz", m.physics_rate_hz, Quantity::kPhysicsRate});
  e.push_back({"simulation", "gravity_m_s2", m.gravity_m_s2, Quantity::kGravity});
  if (m.knee_parallel_spring.stiffness_nm_per_rad != 0.0) {
    e.push_back({"knee_parallel_spring", "stiffness_nm_per_rad", m.knee_parallel_spring.stiffness_nm_per_rad, Quantity::kJointStiffness});
  }
  // Values of parts this model does not have (a two-segment leg has no foot, no ankle and no biarticular
  // spring; a directly driven knee no series spring and no position loop) are not its values: not checked.
  const auto absent = [&](const Entry& x) {
    const std::string section = x.section, key = x.key;
    if (!m.has_ankle && (section == "foot" || section == "biarticular_spring" || key == "ankle_range_rad")) return true;
    return m.knee_drive == PlanarLegModel::KneeDrive::kPositionPd && (section == "knee_spring" || key == "bandwidth_per_s");
  };
  for (const Entry& x : e) {
    if (absent(x)) continue;
    const PhysicalRange& r = range_for(x.quantity);
    if (!(x.value >= r.low && x.value <= r.high)) {  // NaN fails too
      return RangeProblem{x.section, x.key,
                          fmt::format("{:g} is outside the physical range [{:g}, {:g}] ({})", x.value, r.low, r.high, r.why)};
    }
  }
  // The knee's position loop is stepped explicitly once per physics step: speed = bandwidth * error moves
  // past its target (and rings) when bandwidth * dt > 1.
  if (m.knee_drive == PlanarLegModel::KneeDrive::kSeriesElastic && m.knee_motor_bandwidth_per_s > m.physics_rate_hz) {
    return RangeProblem{"knee_motor", "bandwidth_per_s",
                        fmt::format("{:g}/s is above simulation.physics_rate_hz ({:g} Hz): the explicit position "
                                    "loop would overshoot every step", m.knee_motor_bandwidth_per_s, m.physics_rate_hz)};
  }
  return std::nullopt;
}

}  // namespace cpgmatch::sim
