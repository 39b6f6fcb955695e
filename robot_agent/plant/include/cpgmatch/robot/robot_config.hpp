// The robot description the agent and the emulator share (configs/robot/morti.yaml): which motor answers
// on which node id, how motor-shaft values map onto the Plant's joint coordinates, the limits, the
// sensor nodes and the safety settings. Joint coordinates are the Plant's (plant.hpp): the hip angle
// (+ moves the foot forward) and the knee flexion on top of the standing knee angle.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <utility>

#include "cpgmatch/legs.hpp"
#include "cpgmatch/params.hpp"
#include "cpgmatch/robot/mit_protocol.hpp"

namespace cpgmatch::robot {

// The legs this hardware description knows: Morti's layout (joints FL_hip ... HR_knee, feet FL ... HR).
// A hardware description by joint names from the robot's YAML replaces it (issue 31).
inline constexpr std::size_t kHardwareLegs = 4;
inline constexpr std::array<std::string_view, kHardwareLegs> kHardwareLegNames{"FL", "FR", "HL", "HR"};

struct JointConfig {
  std::string name;                  // FL_hip, FL_knee, ...
  std::uint32_t node_id = 0;
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
  std::string protocol = "mit";
  // A description for emulators only (tests, benchmarks on a shared machine): its watchdog timeout may
  // exceed what keeps the 20 ms safety target, and the agent refuses to drive a socketcan: bus with it.
  bool emulator_only = false;
  std::uint32_t host_id = 0;              // CAN id the motors reply on
  MitRanges ranges;                       // the firmware's ranges (motor-shaft units)
  double control_rate_hz = 500.0;
  PerLeg<JointConfig> hips = PerLeg<JointConfig>(kHardwareLegs);
  PerLeg<JointConfig> knees = PerLeg<JointConfig>(kHardwareLegs);
  PerLeg<std::uint32_t> foot_node_ids = PerLeg<std::uint32_t>(kHardwareLegs, 0);
  std::uint32_t trunk_node_id = 0;        // and trunk_node_id + 1
  SafetyConfig safety;

  // Why `params` may not run on the robot ("hip_amplitude = 0.7 is outside the safe envelope ..."),
  // or nullopt.
  std::optional<std::string> envelope_violation(const CpgParameters& params) const;
};

// Loads and checks a robot YAML. Throws InputError naming file:line and field: unknown or missing
// joints, a missing or duplicate node id, limits the motor's ranges cannot represent, and so on.
RobotConfig load_robot_config(const std::string& path);

// configs/robot/morti.yaml under $CPGMATCH_CONFIG_DIR, else the source tree's configs/.
std::string default_robot_config_path();

}  // namespace cpgmatch::robot
