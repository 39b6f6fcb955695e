// The robot's hardware description the agent and the emulator share (configs/robot/*.yaml): its legs,
// and per joint which leg it belongs to and whether it is that leg's hip or knee, the motor protocol and
// node id that drive it, how motor-shaft values map onto the Plant's joint coordinates, the limits and
// gains; the foot and trunk sensors' CAN frame ids; the safety settings, per robot and per joint.
// Joint coordinates are the Plant's (plant.hpp): the hip angle (+ moves the foot forward) and the knee
// flexion on top of the standing knee angle.
//
// Nothing here assumes a number of legs: the legs are a list, the joints a list (up to kMaxLegs legs, what
// the Plant interface carries).
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "cpgmatch/legs.hpp"
#include "cpgmatch/params.hpp"
#include "cpgmatch/robot_description.hpp"
#include "cpgmatch/robot/mit_protocol.hpp"
#include "cpgmatch/robot/moteus_protocol.hpp"
#include "cpgmatch/robot/odrive_protocol.hpp"

namespace cpgmatch::robot {

enum class JointRole { kHip, kKnee };
const char* to_string(JointRole role);

struct JointConfig {
  std::string name;                  // as the robot names it (FL_hip, FL_knee_joint, ...)
  std::string origin;                // file:line of its entry, for messages
  int leg = 0;                       // index into RobotConfig::legs
  JointRole role = JointRole::kHip;
  std::string protocol = "mit";      // mit | odrive | moteus
  std::uint32_t node_id = 0;         // MIT node 1..255, ODrive node 0..63, moteus servo 1..127
  MitRanges mit_ranges;              // mit: the firmware's ranges
  OdriveSettings odrive;             // odrive: torque constant, Iq request
  MoteusSettings moteus;             // moteus: the servo's configured gains, the host id
  // Per-joint safety; unset: the robot's safety section (RobotConfig::feedback_timeout_s(j) etc.).
  std::optional<double> feedback_timeout_s;
  std::optional<double> safe_damping_nm_s_per_rad;
  double gear_ratio = 1.0;           // motor output-shaft radians per joint radian (> 0)
  int direction = 1;                 // +1, or -1 when the motor turns against the joint's + sense
  double zero_offset_rad = 0.0;      // joint angle at motor position 0
  double position_min_rad = 0.0;
  double position_max_rad = 0.0;
  double velocity_max_rad_s = 0.0;   // measured faster than this: unsafe, the watchdog trips
  double torque_max_nm = 0.0;        // commands are bounded so that the motor's torque stays below
  double kp_nm_per_rad = 0.0;        // joint-side impedance gains sent with every command
  double kd_nm_s_per_rad = 0.0;

  double to_motor_position(double joint_rad) const { return direction * gear_ratio * (joint_rad - zero_offset_rad); }
  double to_joint_position(double motor_rad) const { return zero_offset_rad + motor_rad / (direction * gear_ratio); }
  double to_joint_velocity(double motor_rad_s) const { return motor_rad_s / (direction * gear_ratio); }
  double to_motor_velocity(double joint_rad_s) const { return joint_rad_s * direction * gear_ratio; }
  double to_joint_torque(double motor_nm) const { return motor_nm * direction * gear_ratio; }
  double to_motor_torque(double joint_nm) const { return joint_nm / (direction * gear_ratio); }
  // Gains scale with the square of the ratio; the direction cancels.
  double to_motor_kp(double joint_kp) const { return joint_kp / (gear_ratio * gear_ratio); }
  double to_motor_kd(double joint_kd) const { return joint_kd / (gear_ratio * gear_ratio); }
  double to_joint_kp(double motor_kp) const { return motor_kp * gear_ratio * gear_ratio; }
  double to_joint_kd(double motor_kd) const { return motor_kd * gear_ratio * gear_ratio; }
};

struct SafetyConfig {
  double feedback_timeout_s = 0.010;     // a motor silent this long trips the watchdog
  int max_consecutive_overruns = 5;      // control periods in a row that missed their deadline
  double safe_damping_nm_s_per_rad = 0.5;// joint-side damping of the safe state (kp = 0, t = 0)
  double stand_ramp_speed_rad_s = 0.5;   // joint speed of the ramp to the standing pose
  double stand_tolerance_rad = 0.02;     // closer than this to the standing pose: no ramp needed
  // Candidate parameters allowed on the robot: name -> [low, high]. Parameters not listed are not limited
  // beyond their valid range.
  std::map<std::string, std::pair<double, double>> envelope;
  std::map<std::string, std::string> envelope_origin;  // name -> file:line, for refusal messages
};

struct RobotConfig {
  std::string source;                     // the file it came from
  // The robot description (configs/robots/NAME/) of this body; empty: the file does not say. A study of
  // another robot is refused (study_robot_mismatch).
  std::string robot;
  std::string protocol = "mit";           // the default of joints that name no protocol
  // A description for emulators only (tests, benchmarks on a shared machine): its watchdog timeout may
  // exceed what keeps the 20 ms safety target, and the agent refuses to drive a socketcan: bus with it.
  bool emulator_only = false;
  std::uint32_t host_id = 0;              // MIT: the CAN id motors reply on; moteus: the agent's source id
  MitRanges ranges;                       // MIT joints' default firmware ranges (motor-shaft units)
  double control_rate_hz = 500.0;
  std::vector<std::string> legs;          // leg names in the controller's order
  std::vector<JointConfig> joints;        // in the file's order
  std::vector<std::uint32_t> foot_frame_ids;  // per leg: the foot sensor's CAN id (standard)
  std::uint32_t trunk_pose_frame_id = 0;  // the trunk sensor's pose frame (standard id)
  std::uint32_t trunk_speed_frame_id = 0; // and its speed frame
  SafetyConfig safety;

  int leg_count() const { return static_cast<int>(legs.size()); }
  int joint_count() const { return static_cast<int>(joints.size()); }
  // The joint of `leg` with `role` (every leg has exactly one hip and one knee once loaded).
  int joint_index(int leg, JointRole role) const;
  const JointConfig& joint(int leg, JointRole role) const { return joints[joint_index(leg, role)]; }
  const JointConfig& hip(int leg) const { return joint(leg, JointRole::kHip); }
  const JointConfig& knee(int leg) const { return joint(leg, JointRole::kKnee); }
  // A joint's safety values: its own, else the robot's.
  double feedback_timeout_s(const JointConfig& j) const { return j.feedback_timeout_s.value_or(safety.feedback_timeout_s); }
  double safe_damping(const JointConfig& j) const { return j.safe_damping_nm_s_per_rad.value_or(safety.safe_damping_nm_s_per_rad); }
  // Some joint's protocol needs CAN-FD frames (moteus).
  bool needs_fd() const;
  // Why this description cannot drive the Plant interface (1 to kMaxLegs legs), or nullopt.
  std::optional<std::string> plant_mismatch() const;

  // Why a study of `study_robot` may not run on this body, or nullopt: its name is not this file's `robot`,
  // or its legs' hip and knee joints are not the joints this file drives. The reason names both.
  std::optional<std::string> study_robot_mismatch(const RobotDescription& study_robot) const;

  // Why `params` may not run on the robot ("hip_amplitude = 0.7 is outside the safe envelope ..."),
  // or nullopt.
  std::optional<std::string> envelope_violation(const CpgParameters& params) const;
};

// Loads and checks a robot YAML. Throws InputError naming file:line and field: a joint without a leg or
// role, a leg without a hip or a knee, an unknown protocol, a node id outside its protocol's range, two
// joints (or a joint and a sensor) on one CAN id of their id space, limits a protocol cannot represent...
RobotConfig load_robot_config(const std::string& path);

// The motor protocol object (motor_factory.hpp) for a loaded joint.
std::unique_ptr<MotorProtocol> make_joint_protocol(const JointConfig& joint);

// configs/robot/morti.yaml under $CPGMATCH_CONFIG_DIR, else the source tree's configs/.
std::string default_robot_config_path();

}  // namespace cpgmatch::robot
