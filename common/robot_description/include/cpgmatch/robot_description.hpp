// A legged robot as data: its URDF (links, masses, inertias, joints, limits, collision shapes) and a small
// robot.yaml beside it for what a URDF cannot say (which joints form each leg, springs, motors, contact,
// the CPG's leg groups, gait presets and the search space). See docs/your-robot.md.
//
// This is the run-time description every part of cpgmatch reads a robot from, in the spirit of
// ros2_control's HardwareInfo: plain data, no physics engine, no bus, no DDS. The loader
// (robot_description_loader.hpp) fills it with urdfdom and checks it; the simulation and the robot agent
// build their bodies from it.
//
// Frames and units are the URDF's: x forward, y left, z up; metres, kilograms, radians, seconds. A joint's
// zero is the pose the URDF describes, which for cpgmatch robots is the standing pose.
#pragma once

#include <array>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace cpgmatch {

struct Vec3 {
  double x = 0.0, y = 0.0, z = 0.0;
};

// A pose in its parent's frame: translation, then roll-pitch-yaw (URDF's fixed-axis x-y-z order).
struct Origin {
  Vec3 xyz;
  Vec3 rpy;
};

struct CollisionShape {
  enum class Kind { kBox, kSphere, kCylinder };
  Kind kind = Kind::kSphere;
  Origin origin;     // in the link's frame
  Vec3 box_size_m;   // kBox: full edge lengths along the shape's x, y, z
  double radius_m = 0.0;  // kSphere, kCylinder
  double length_m = 0.0;  // kCylinder, along its z
};

struct LinkDescription {
  std::string name;
  std::string where;  // "robot.urdf:12", for messages
  double mass_kg = 0.0;
  Origin inertial_origin;  // centre of mass and the inertia's axes, in the link's frame
  // About the centre of mass, in the inertial frame: ixx, ixy, ixz, iyy, iyz, izz (kg m^2).
  std::array<double, 6> inertia_kg_m2{};
  std::vector<CollisionShape> collisions;
};

enum class JointType { kRevolute, kContinuous, kPrismatic, kFixed, kOther };
const char* to_string(JointType type);

struct JointDescription {
  std::string name;
  std::string where;
  JointType type = JointType::kFixed;
  std::string parent_link;
  std::string child_link;
  Origin origin;       // the child's frame in the parent's at joint position 0
  Vec3 axis{1, 0, 0};  // in the child's (= joint's) frame
  bool limited = false;       // revolute and prismatic joints have limits; continuous ones do not
  double lower = 0.0;         // rad (m for prismatic)
  double upper = 0.0;
  double effort_limit = 0.0;  // N m (N)
  double velocity_limit = 0.0;  // rad/s (m/s)
};

// One leg: a hip and a knee, an optional passive ankle, and the link whose collision shape touches the
// ground (its foot contact sensor).
struct LegDescription {
  std::string name;   // as the robot's YAML names it (FL, L1, ...): used in traces, plots, the wire
  std::string group;  // legs of one group share the CPG's per-group parameters (e.g. front, hind)
  std::string hip_joint;
  std::string knee_joint;
  std::string ankle_joint;  // empty: no ankle
  std::string foot_link;
};

// A motor as its torque-speed line at the joint (after the gearbox) and what its gearbox adds.
struct MotorDescription {
  std::string name;
  double stall_torque_nm = 0.0;
  double no_load_speed_rad_s = 0.0;
  double gear_ratio = 1.0;                     // motor turns per joint turn (informational for the sim)
  double coulomb_friction_nm = 0.0;            // gearbox dry friction at the joint
  double viscous_friction_nm_s_per_rad = 0.0;  // gearbox viscous drag at the joint
  double reflected_inertia_kg_m2 = 0.0;        // rotor inertia x gear ratio^2, about the joint
};

struct SpringDescription {
  double stiffness_nm_per_rad = 0.0;
  double damping_nm_s_per_rad = 0.0;
};

// How a role's joint (every leg's hip, knee or ankle) is driven.
struct DriveDescription {
  enum class Kind {
    kPositionPd,     // the motor drives the joint directly: a PD on the joint angle within its torque-speed line
    kSeriesElastic,  // the motor positions the rest angle of a spring in series with the joint
    kPassive,        // no motor
  };
  Kind kind = Kind::kPassive;
  std::string motor;                // kPositionPd, kSeriesElastic: a key of RobotDescription::motors
  double kp_nm_per_rad = 0.0;       // kPositionPd
  double kd_nm_s_per_rad = 0.0;     // kPositionPd
  SpringDescription series_spring;  // kSeriesElastic
  double bandwidth_per_s = 0.0;     // kSeriesElastic: the motor's position loop, speed = bandwidth x error
  double joint_friction_nm = 0.0;   // dry friction of the joint's own bearing
};
const char* to_string(DriveDescription::Kind kind);

// A spring between two links of a leg, torque on their relative rotation, at rest in the standing pose
// (Morti's biarticular spring holds the foot parallel to the femur).
struct ParallelSpringDescription {
  std::string name;
  std::string from_role;  // "hip" (the femur), "knee" (the shank) or "ankle" (the foot): the link after that joint
  std::string to_role;
  SpringDescription spring;
};

struct ContactDescription {
  double friction = 0.8;
  double stiffness_n_per_m = 5e4;
  double damping_n_s_per_m = 150.0;
};

struct FootSensorDescription {
  double sensitivity = 1.0;      // reported force / contact force
  double time_constant_s = 0.0;  // first-order lag of the reported force
};

struct GaitPreset {
  std::string name;
  std::vector<double> phase_offsets;  // cycles, one per leg in the order of RobotDescription::legs
};

struct SearchParameter {
  std::string name;
  double low = 0.0;
  double high = 0.0;
  std::string unit;
};

struct RobotDescription {
  std::string name;
  std::string summary;        // one line: what the robot is, where its values come from
  std::string yaml_source;    // the robot.yaml's path (or a stand-in name for text from a study spec)
  std::string urdf_source;
  std::string yaml_text;      // both texts, as read: the study spec holds them and hashes them
  std::string urdf_text;

  std::string root_link;      // the trunk
  std::vector<LinkDescription> links;
  std::vector<JointDescription> joints;

  // true: a rail or boom keeps the trunk in the sagittal plane (forward, up, pitch); false: the robot stands
  // on its own, free in 3D (its hips' URDF y then place the legs on its sides).
  bool planar = true;
  std::vector<LegDescription> legs;
  std::vector<std::string> groups;  // in first-use order
  std::map<std::string, MotorDescription> motors;
  std::map<std::string, DriveDescription> drives;  // by role: hip, knee, ankle
  std::vector<ParallelSpringDescription> parallel_springs;
  ContactDescription contact;
  FootSensorDescription foot_sensor;
  double physics_rate_hz = 1000.0;
  double gravity_m_s2 = 9.81;

  std::vector<GaitPreset> gaits;  // the first is the default
  std::map<std::string, std::map<std::string, double>> presets;  // name -> CPG parameter values
  std::vector<SearchParameter> search_space;

  const LinkDescription& link(const std::string& name) const;   // throws std::out_of_range
  const JointDescription& joint(const std::string& name) const;
  const LinkDescription* find_link(const std::string& name) const;
  const JointDescription* find_joint(const std::string& name) const;
  const GaitPreset* find_gait(const std::string& name) const;
  double total_mass_kg() const;
  std::size_t leg_count() const { return legs.size(); }
};

}  // namespace cpgmatch
