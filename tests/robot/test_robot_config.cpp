// The robot YAML: the shipped Morti file loads; bad files fail with file:line and the field.
#include <filesystem>
#include <fstream>
#include <regex>
#include <vector>

#include <gtest/gtest.h>

#include "cpgmatch/errors.hpp"
#include "cpgmatch/robot/robot_config.hpp"
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
  EXPECT_EQ(c.hips[kFrontLeft].node_id, 1u);
  EXPECT_EQ(c.knees[kHindRight].node_id, 8u);
  EXPECT_EQ(c.hips[kFrontRight].direction, -1);
  EXPECT_EQ(c.foot_node_ids[kHindLeft], 35u);
  EXPECT_EQ(c.trunk_node_id, 64u);
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
  expect(error_after("FL_knee:", "FL_ankle:"), "field 'joints.FL_ankle': unknown joint");
  expect(error_after(R"(FR_hip:  \{node_id: 3, )", "FR_hip:  {"), "field 'joints.FR_hip.node_id': is missing");
  expect(error_after(R"(FR_hip:  \{node_id: 3,)", "FR_hip:  {node_id: 1,"), "node id 1 is already used by FL_hip");
  expect(error_after(R"(FL: \{node_id: 33\})", "FL: {node_id: 2}"), "node id 2 is already used by FL_knee");
  expect(error_after("torque_max_nm: 4.0", "torque_max_nm: 40.0"), "beyond the protocol's +-18 N m");
  expect(error_after("position_max_rad: 1.4", "position_max_rad: 14"), "outside the protocol's +-12.5 rad");
  expect(error_after("direction: 1,", "direction: 2,"), "must be 1 or -1");
  expect(error_after("protocol: mit", "protocol: odrive"), "'odrive' is not supported");
  expect(error_after(R"(hip_amplitude: \[0.05, 0.65\])", "hip_amplitude: [0.05, 0.95]"), "outside the parameter's valid range");
  expect(error_after(R"(hip_amplitude: \[0.05, 0.65\])", "hip_amplitud: [0.05, 0.6]"), "unknown parameter");
  expect(error_after("feedback_timeout_s: 0.010", "feedback_timeout_s: 0.05"), "feedback_timeout_s");
  expect(error_after("  HR_knee:.*\n", ""), "field 'joints.HR_knee': is missing");
}

}  // namespace
}  // namespace cpgmatch::robot
