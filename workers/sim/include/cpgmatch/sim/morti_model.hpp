// The ODE plant's mechanical model of a planar legged robot: every mass, length, stiffness and motor limit.
//
// It is built from a robot description (planar_leg_model.hpp) or read from a model file such as
// configs/model/morti.yaml (Morti's, which documents the source of each number). Its defaults are Morti's,
// whose geometry is the biarticular leg: hip -> femur -> knee -> shank -> ankle -> foot -> toe, with the foot held parallel
// to the femur by the biarticular spring (the spring-loaded parallel mechanism), and the knee driven by
// its motor through the monoarticular knee spring (series elastic).
#pragma once

#include <string>
#include <vector>

#include "cpgmatch/robot_description.hpp"

namespace cpgmatch {
class YamlReader;
}

namespace cpgmatch::sim {

struct SegmentModel {
  double length_m = 0.12;
  double mass_kg = 0.1;
};

struct MotorModel {
  double stall_torque_nm = 4.0;      // torque limit at zero speed
  double no_load_speed_rad_s = 12.0; // speed at which the available torque reaches zero
  double kp_nm_per_rad = 40.0;       // position gain (hip: torque PD; knee: see knee_motor_bandwidth)
  double kd_nm_s_per_rad = 0.6;      // damping gain of the hip PD
  // The gearbox as seen at the joint, active or passive: a geared motor is never a free hinge.
  double coulomb_friction_nm = 0.0;           // dry friction of gears and bearings, N m
  double viscous_friction_nm_s_per_rad = 0.0; // viscous drag, N m s/rad
  double reflected_inertia_kg_m2 = 0.0;       // rotor inertia times gear ratio squared, about the joint
};

struct SpringModel {
  double stiffness_nm_per_rad = 10.0;
  double damping_nm_s_per_rad = 0.02;
};

using ContactModel = ContactDescription;  // robot_description.hpp: friction, stiffness, damping

// The FootTile as a force sensor: what the robot reports as a foot's normal force. An ideal sensor
// (sensitivity 1, no lag) reports the contact force itself; a worn or soft polyurethane dome passes less of
// the force to its barometer (sensitivity < 1) and lags it (viscoelastic creep of the dome plus the
// barometer's oversampling filter, a first-order lag), so the rollout's threshold is crossed later.
using FootSensorModel = FootSensorDescription;  // robot_description.hpp: sensitivity, lag

struct PlanarLegModel {
  double trunk_mass_kg = 3.0;
  double trunk_length_m = 0.48;   // box length; hips sit at +-hip_spacing/2
  double hip_spacing_m = 0.40;
  double trunk_height_m = 0.05;
  double trunk_depth_m = 0.15;
  SegmentModel femur{0.12, 0.10};
  SegmentModel shank{0.12, 0.08};
  SegmentModel foot{0.07, 0.04};
  double toe_radius_m = 0.012;
  double femur_mount_angle_rad = 0.5;   // femur direction from straight down at hip angle 0; + forward
  double knee_stand_flexion_rad = 1.0;  // knee flexion at knee target 0
  double knee_min_flexion_rad = 0.2;
  double knee_max_flexion_rad = 2.4;
  double ankle_range_rad = 1.2;         // ankle (foot vs shank) stops, +- this from the standing pose
  double knee_joint_friction_nm = 0.0;  // dry friction of the knee bearing, N m
  SpringModel knee_spring{15.0, 0.05};        // in series with the knee motor (kSeriesElastic)
  SpringModel biarticular_spring{4.0, 0.01};  // foot to femur (legs with an ankle)
  // A spring across the knee, parallel to its motor, at rest in the standing pose; stiffness 0: none.
  SpringModel knee_parallel_spring{0.0, 0.0};
  // Three segments (femur, shank, foot held by the biarticular spring) or two (the toe at the shank's end).
  bool has_ankle = true;
  // How the knee motor drives the knee: positioning the rest angle of the series knee spring (Morti), or
  // directly, a PD on the knee flexion with knee_motor's gains within its torque-speed line.
  enum class KneeDrive { kSeriesElastic, kPositionPd };
  KneeDrive knee_drive = KneeDrive::kSeriesElastic;
  MotorModel hip_motor{4.0, 12.0, 40.0, 0.6};
  MotorModel knee_motor{4.0, 12.0, 0.0, 0.0};
  double knee_motor_bandwidth_per_s = 60.0;  // knee motor position loop: speed = bandwidth * error
  ContactModel contact;
  FootSensorModel foot_sensor;
  double physics_rate_hz = 1000.0;
  double gravity_m_s2 = 9.81;
  // Fore-aft position of each leg's hip on the trunk (m, + forward), one per leg in the robot's leg order.
  // Empty: Morti's four legs FL FR HL HR at +-hip_spacing_m / 2 (a model file gives no layout).
  std::vector<double> hip_x_m;
  // On a rail or boom (the trunk moves forward, up and pitches only; the legs of one side overlap the
  // other's in the sagittal plane) or free in 3D (a robot standing on its own: roll, yaw and sideways
  // motion too). Free needs hip_lateral_m; a model file is always planar.
  bool planar = true;
  // Sideways position of each leg's hip (m, + left, the URDF's y), in the robot's leg order; read only when
  // the robot is free.
  std::vector<double> hip_lateral_m;

  std::vector<double> hip_positions_m() const {
    if (!hip_x_m.empty()) return hip_x_m;
    return {0.5 * hip_spacing_m, 0.5 * hip_spacing_m, -0.5 * hip_spacing_m, -0.5 * hip_spacing_m};
  }
  std::size_t leg_count() const { return hip_positions_m().size(); }
  double total_mass_kg() const {
    return trunk_mass_kg + static_cast<double>(leg_count()) * (femur.mass_kg + shank.mass_kg + (has_ankle ? foot.mass_kg : 0.0));
  }
};

// Loads a model file (configs/model/*.yaml: Morti's and the reality-gap overlays; absent keys keep Morti's
// defaults above); throws InputError naming the file, line and field on bad input.
PlanarLegModel load_model_file(const std::string& path);
// The same from a parsed tree (a study spec's model section); errors name the reader's source.
PlanarLegModel parse_model_file(const YamlReader& reader);

}  // namespace cpgmatch::sim
