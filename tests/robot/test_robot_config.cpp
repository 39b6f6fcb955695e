// The robot YAML: the shipped Morti file loads; bad files fail with file:line and the field.
#include <filesystem>
#include <fstream>
#include <regex>
#include <vector>

#include <gtest/gtest.h>

#include "cpgmatch/errors.hpp"
#include "cpgmatch/robot/robot_config.hpp"
#include "cpgmatch/robot_description_loader.hpp"
#include "../support/morti_legs.hpp"

using namespace cpgmatch::test;  // Morti's legs: FL FR HL HR

namespace cpgmatch::robot {
namespace {

std::string shipped_text() {
  std::ifstream in(default_robot_config_path());
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

// Loads the shipped file with regex replacements applied (each to its first match); returns the error
// message ("" if none).
std::string error_after_all(const std::vector<std::pair<std::string, std::string>>& edits) {
  std::string text = shipped_text();
  for (const auto& [pattern, replacement] : edits) {
    text = std::regex_replace(text, std::regex(pattern), replacement, std::regex_constants::format_first_only);
  }
  const auto path = std::filesystem::temp_directory_path() / ("robot-" + std::to_string(::getpid()) + ".yaml");
  std::ofstream(path) << text;
  std::string message;
  try {
    load_robot_config(path.string());
  } catch (const InputError& e) {
    message = e.what();
  }
  std::filesystem::remove(path);
  return message;
}

std::string error_after(const std::string& pattern, const std::string& replacement) {
  return error_after_all({{pattern, replacement}});
}

TEST(RobotConfig, ShippedMortiLoads) {
  const RobotConfig c = load_robot_config(default_robot_config_path());
  EXPECT_EQ(c.protocol, "mit");
  EXPECT_EQ(c.hip(kFrontLeft).node_id, 1u);
  EXPECT_EQ(c.knee(kHindRight).node_id, 8u);
  EXPECT_EQ(c.hip(kFrontRight).direction, -1);
  EXPECT_EQ(c.foot_frame_ids[kHindLeft], 35u);
  EXPECT_EQ(c.trunk_pose_frame_id, 64u);
  EXPECT_DOUBLE_EQ(c.control_rate_hz, 500.0);
  EXPECT_DOUBLE_EQ(c.safety.feedback_timeout_s, 0.010);
  EXPECT_EQ(c.safety.envelope.size(), 8u);
}

TEST(RobotConfig, JointUnitConversionsInvertEachOther) {
  JointConfig j;
  j.gear_ratio = 6.0;
  j.direction = -1;
  j.zero_offset_rad = 0.3;
  EXPECT_NEAR(j.to_joint_position(j.to_motor_position(0.7)), 0.7, 1e-12);
  EXPECT_NEAR(j.to_motor_position(0.3), 0.0, 1e-12);
  EXPECT_NEAR(j.to_motor_position(0.4), -0.6, 1e-12);
  EXPECT_NEAR(j.to_joint_torque(j.to_motor_torque(2.0)), 2.0, 1e-12);
  EXPECT_NEAR(j.to_motor_torque(6.0), -1.0, 1e-12);
  EXPECT_NEAR(j.to_motor_kp(36.0), 1.0, 1e-12);
  EXPECT_NEAR(j.to_joint_velocity(j.to_motor_velocity(-3.0)), -3.0, 1e-12);
}

TEST(RobotConfig, EnvelopeRefusesWithTheReason) {
  const RobotConfig c = load_robot_config(default_robot_config_path());
  CpgParameters p;
  EXPECT_FALSE(c.envelope_violation(p).has_value());
  p.hip_amplitude = 0.69;
  const auto why = c.envelope_violation(p);
  ASSERT_TRUE(why.has_value());
  EXPECT_NE(why->find("hip_amplitude = 0.69 is outside the robot's safe envelope [0.05, 0.65]"), std::string::npos) << *why;
  EXPECT_NE(why->find("morti.yaml:"), std::string::npos) << *why;
}

TEST(RobotConfig, OnlyEmulatorDescriptionsMayHaveASlowWatchdog) {
  EXPECT_NE(error_after("feedback_timeout_s: 0.010", "feedback_timeout_s: 0.5").find("must be in [0.002, 0.015]"),
            std::string::npos);
  EXPECT_EQ(error_after_all({{"feedback_timeout_s: 0.010", "feedback_timeout_s: 0.5"},
                             {"\nprotocol: mit", "\nemulator_only: true\nprotocol: mit"}}),
            "");
}

TEST(RobotConfig, BadFilesNameFileLineAndField) {
  auto expect = [](const std::string& message, const std::string& part) {
    EXPECT_NE(message.find(part), std::string::npos) << "got: " << message;
    EXPECT_TRUE(std::regex_search(message, std::regex(R"(\.yaml:\d+)"))) << "no file:line in: " << message;
  };
  expect(error_after(R"(FR_hip:  \{leg: FR, role: hip,  node_id: 3, )", "FR_hip:  {leg: FR, role: hip, "),
         "field 'joints.FR_hip.node_id': is missing");
  expect(error_after(R"(FR_hip:  \{leg: FR, role: hip,  node_id: 3,)", "FR_hip:  {leg: FR, role: hip, node_id: 1,"),
         "CAN id 0x1 of FR_hip (mit node 1) is already used by FL_hip (mit node 1)");
  expect(error_after(R"(FL: \{frame_id: 33\})", "FL: {frame_id: 2}"), "CAN id 0x2 of FL foot sensor is already used by FL_knee (mit node 2)");
  expect(error_after("torque_max_nm: 4.0", "torque_max_nm: 40.0"), "beyond the protocol's +-18 N m");
  expect(error_after("position_max_rad: 1.4", "position_max_rad: 14"), "outside the protocol's +-12.5 rad");
  expect(error_after("direction: 1,", "direction: 2,"), "must be 1 or -1");
  expect(error_after("protocol: mit", "protocol: canopen"), "field 'protocol': 'canopen' is not a motor protocol (known: mit, odrive, moteus)");
  expect(error_after(R"(hip_amplitude: \[0.05, 0.65\])", "hip_amplitude: [0.05, 0.95]"), "outside the parameter's valid range");
  expect(error_after(R"(hip_amplitude: \[0.05, 0.65\])", "hip_amplitud: [0.05, 0.6]"), "unknown parameter");
  expect(error_after("feedback_timeout_s: 0.010", "feedback_timeout_s: 0.05"), "feedback_timeout_s");
  // Issue 31: joints by name, each naming its leg and role; a description's own mistakes.
  expect(error_after("  HR_knee:.*\n", ""), "leg HR has no knee joint");
  expect(error_after("FL_hip:  \\{leg: FL, ", "FL_hip:  {"), "field 'joints.FL_hip.leg': is missing");
  expect(error_after("leg: HL, role: hip", "leg: HX, role: hip"), "field 'joints.HL_hip.leg': 'HX' is not one of the robot's legs (FL, FR, HL, HR)");
  expect(error_after("leg: HL, role: hip", "leg: HL, role: ankle"), "field 'joints.HL_hip.role': 'ankle' is not hip or knee");
  expect(error_after("leg: HL, role: hip", "leg: FL, role: hip"), "field 'joints.HL_hip.role': leg FL already has a hip (FL_hip)");
  expect(error_after("FL_knee: \\{leg: FL, role: knee, ", "FL_knee: {leg: FL, role: knee, protocol: odrv, "),
         "field 'joints.FL_knee.protocol': 'odrv' is not a motor protocol");
  expect(error_after("  FL: \\{frame_id: 33\\}\n", ""), "field 'feet.FL': is missing");
  expect(error_after("legs: \\[FL, FR, HL, HR\\]", "legs: [FL, FR, HL, HR, FL]"), "leg 'FL' is listed twice");
  expect(error_after("trunk_sensor: \\{pose_frame_id: 64, speed_frame_id: 65\\}", "trunk_sensor: {pose_frame_id: 64, speed_frame_id: 33}"),
         "CAN id 0x21 of the trunk sensor's speed frame is already used by FL foot sensor");
  // A joint on another protocol: an ODrive node owns 32 ids, so node 0 clashes with the MIT host id 0 and
  // node 1 (ids 0x20..0x3F) with the FL foot sensor on 33.
  expect(error_after("FL_knee: \\{leg: FL, role: knee, node_id: 2, ", "FL_knee: {leg: FL, role: knee, protocol: odrive, torque_constant_nm_per_a: 0.05, node_id: 1, "),
         "CAN id 0x21 of FL foot sensor is already used by FL_knee (odrive node 1)");
  expect(error_after("FL_knee: \\{leg: FL, role: knee, node_id: 2, ", "FL_knee: {leg: FL, role: knee, protocol: odrive, torque_constant_nm_per_a: 0.05, node_id: 0, "),
         "CAN ids 0x0..0x1F of FL_knee (odrive node 0) are already used by FL_hip (mit node 1)");
}

// Each shipped hardware description loads; the ODrive and moteus ones carry their protocol's settings.
TEST(RobotConfig, ShippedOdriveAndMoteusDescriptionsLoad) {
  const std::string dir = std::filesystem::path(default_robot_config_path()).parent_path().string() + "/";
  const RobotConfig odrive = load_robot_config(dir + "odrive-quadruped.yaml");
  ASSERT_EQ(odrive.joint_count(), 8);
  EXPECT_EQ(odrive.hip(kFrontLeft).protocol, "odrive");
  EXPECT_EQ(odrive.knee(kHindRight).node_id, 7u);
  EXPECT_NEAR(odrive.hip(kFrontLeft).odrive.torque_constant_nm_per_a, 0.0243, 1e-12);
  EXPECT_FALSE(odrive.needs_fd());
  EXPECT_FALSE(odrive.plant_mismatch().has_value());
  EXPECT_EQ(odrive.foot_frame_ids[kHindRight], 0x303u);

  const RobotConfig hexapod = load_robot_config(dir + "moteus-hexapod.yaml");
  EXPECT_EQ(hexapod.leg_count(), 6);
  EXPECT_EQ(hexapod.joint_count(), 12);
  EXPECT_TRUE(hexapod.needs_fd());
  EXPECT_EQ(hexapod.knee(5).name, "R3_knee");
  EXPECT_DOUBLE_EQ(hexapod.knee(5).moteus.servo_kp_nm_per_rad, 50.0);
  // The Plant carries six legs (up to kMaxLegs); nine would be more than it carries.
  EXPECT_FALSE(hexapod.plant_mismatch().has_value());
}

// Where a robot description drives a joint by a position PD (the motor's own position loop), the hardware file
// must send that loop the description's gains: the simulation optimises the body with them, and the robot
// must be run with the same drive (the ODrive quadruped's file once had Morti's 40/20 N m/rad and fell where
// its simulation walked). A series-elastic knee's motor gains are the motor's, not the spring's: not compared.
TEST(RobotConfig, ShippedHardwareSendsItsDescriptionsPositionGains) {
  int compared = 0;
  for (const auto& entry : std::filesystem::directory_iterator(std::filesystem::path(default_robot_config_path()).parent_path())) {
    const RobotConfig config = load_robot_config(entry.path().string());
    if (config.robot.empty()) continue;
    SCOPED_TRACE(entry.path().string());
    const RobotDescription robot = load_robot(config.robot);
    for (const JointConfig& joint : config.joints) {
      const DriveDescription& drive = robot.drives.at(joint.role == JointRole::kHip ? "hip" : "knee");
      if (drive.kind != DriveDescription::Kind::kPositionPd) continue;
      EXPECT_DOUBLE_EQ(joint.kp_nm_per_rad, drive.kp_nm_per_rad) << joint.name;
      EXPECT_DOUBLE_EQ(joint.kd_nm_s_per_rad, drive.kd_nm_s_per_rad) << joint.name;
      ++compared;
    }
  }
  EXPECT_GE(compared, 4 + 8 + 12) << "Morti's hips, the quadruped's and the hexapod's joints";
}

// Renaming joints as a URDF would is fine now: names are the robot's, leg and role say what they are.
TEST(RobotConfig, JointNamesAreTheRobots) {
  EXPECT_EQ(error_after_all({{"FL_hip: ", "FL_hip_joint: "}, {"FL_knee:", "FL_knee_joint:"}}), "");
}

}  // namespace
}  // namespace cpgmatch::robot
