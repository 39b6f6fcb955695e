// RobotDevice, the bus side of the motors and sensors (the emulator's core): what the motors are told
// becomes the Plant's joint commands; replies and sensor frames carry the body's state; imperfections.
#include <thread>

#include <gtest/gtest.h>

#include "cpgmatch/can/can_bus.hpp"
#include "cpgmatch/robot/can_plant.hpp"
#include "cpgmatch/robot/mit_protocol.hpp"
#include "cpgmatch/robot/robot_device.hpp"
#include "cpgmatch/robot/sensor_protocol.hpp"
#include "../support/morti_legs.hpp"

using namespace cpgmatch::test;  // Morti's legs: FL FR HL HR

namespace cpgmatch::robot {
namespace {

// Morti's description lists each leg's hip then knee (configs/robot/morti.yaml): joint 2 leg + 0 / 1.
constexpr int kNumJoints = 2 * kNumLegs;
int joint_index(int leg, bool hip) { return leg * 2 + (hip ? 0 : 1); }


using namespace std::chrono_literals;

struct Rig {
  explicit Rig(const std::string& name, DeviceImperfections imperfections = {})
      : config(load_robot_config(default_robot_config_path())),
        host(can::open_can_bus("virtual:" + name)),
        robot_bus(can::open_can_bus("virtual:" + name, can::BusRole::kDevice)),
        device(config, *robot_bus, imperfections) {}
  RobotDevice::Received deliver(const can::CanFrame& f) {
    host->send(f);
    return device.receive(100ms);
  }
  RobotConfig config;
  std::unique_ptr<can::CanBus> host, robot_bus;
  RobotDevice device;
};

PlantState standing(double force) {
  PlantState s;
  s.legs = PerLeg<LegState>(4);
  s.trunk = {0.5, 0.27, 0.02, 0.3};
  for (int leg = 0; leg < kNumLegs; ++leg) {
    s.legs[leg].hip_angle_rad = 0.1 * (leg + 1);
    s.legs[leg].knee_flexion_rad = -0.05;
    s.legs[leg].hip_torque_nm = 1.0;
    s.legs[leg].knee_torque_nm = -0.5;
    s.legs[leg].foot_normal_force_n = force;
  }
  return s;
}

TEST(RobotDevice, CommandsOfEnabledMotorsBecomeJointTargets) {
  Rig rig("device-commands");
  const JointConfig& fr_hip = rig.config.hip(kFrontRight);  // direction -1
  MitMotor motor(fr_hip.node_id, rig.config.host_id, rig.config.ranges);
  MotorCommand c;
  c.position_rad = fr_hip.to_motor_position(0.3);
  c.kp_nm_per_rad = 40.0;
  EXPECT_EQ(rig.deliver(motor.command(c)).event, RobotDevice::Event::kCommand);
  EXPECT_TRUE(rig.device.joint_commands()[kFrontRight].hip_passive) << "a motor out of motor mode ignores commands";
  EXPECT_EQ(rig.deliver(motor.enable()).event, RobotDevice::Event::kEnable);
  const auto got = rig.deliver(motor.command(c));
  EXPECT_EQ(got.joint, joint_index(kFrontRight, true));
  EXPECT_FALSE(rig.device.joint_commands()[kFrontRight].hip_passive);
  EXPECT_NEAR(rig.device.joint_commands()[kFrontRight].hip_angle_rad, 0.3, 1e-3);
  c.kp_nm_per_rad = 0.0;  // the safe state or the reflex's passive hip
  c.kd_nm_s_per_rad = 0.5;
  rig.deliver(motor.command(c));
  EXPECT_TRUE(rig.device.joint_commands()[kFrontRight].hip_passive);
  EXPECT_EQ(rig.deliver(motor.disable()).event, RobotDevice::Event::kDisable);
  EXPECT_FALSE(rig.device.enabled(joint_index(kFrontRight, true)));
  can::CanFrame short_frame = motor.command(c);
  short_frame.length = 6;
  EXPECT_EQ(rig.deliver(short_frame).event, RobotDevice::Event::kIgnored);
}

TEST(RobotDevice, RepliesAndSensorsCarryTheBodyState) {
  Rig rig("device-replies");
  rig.device.update(standing(12.5), 0.0);
  rig.device.reply(joint_index(kHindLeft, true));
  rig.device.send_sensors();
  can::CanFrame f;
  ASSERT_TRUE(rig.host->receive(f, 100ms));
  const JointConfig& hl_hip = rig.config.hip(kHindLeft);
  const auto fb = mit_decode_reply(f, rig.config.host_id, rig.config.ranges);
  ASSERT_TRUE(fb.has_value());
  EXPECT_EQ(fb->node_id, hl_hip.node_id);
  EXPECT_NEAR(hl_hip.to_joint_position(fb->position_rad), 0.3, 1e-3);
  EXPECT_NEAR(hl_hip.to_joint_torque(fb->torque_nm), 1.0, 0.01);
  ASSERT_TRUE(rig.host->receive(f, 100ms));
  EXPECT_NEAR(decode_foot(f, rig.config.foot_frame_ids[kFrontLeft])->force_n, 12.5, 0.01);
  for (int i = 0; i < 3; ++i) ASSERT_TRUE(rig.host->receive(f, 100ms));
  ASSERT_TRUE(rig.host->receive(f, 100ms));
  const auto trunk = decode_trunk_pose(f, rig.config.trunk_pose_frame_id);
  ASSERT_TRUE(trunk.has_value());
  EXPECT_NEAR(trunk->height_m, 0.27, 1e-4);
  ASSERT_TRUE(rig.host->receive(f, 100ms));
  EXPECT_NEAR(*decode_trunk_speed(f, rig.config.trunk_speed_frame_id), 0.3, 1e-3);
}

TEST(RobotDevice, VelocityIsTheChangeOverTheStep) {
  Rig rig("device-velocity");
  PlantState s = standing(0.0);
  rig.device.update(s, 0.0);
  s.legs[kFrontLeft].hip_angle_rad += 0.002;
  rig.device.update(s, 0.001);
  rig.device.reply(joint_index(kFrontLeft, true));
  can::CanFrame f;
  ASSERT_TRUE(rig.host->receive(f, 100ms));
  EXPECT_NEAR(mit_decode_reply(f, 0, rig.config.ranges)->velocity_rad_s, 2.0, 0.02);
}

TEST(RobotDevice, ImperfectionsDropAndDelayFrames) {
  DeviceImperfections lossy;
  lossy.reply_dropout = 1.0;
  lossy.contact_dropout = 1.0;
  Rig rig("device-lossy", lossy);
  rig.device.update(standing(20.0), 0.0);
  rig.device.reply_all();
  rig.device.send_sensors();
  can::CanFrame f;
  ASSERT_TRUE(rig.host->receive(f, 100ms));
  EXPECT_EQ(f.id, rig.config.foot_frame_ids[kFrontLeft]) << "every reply was lost, the foot frames came";
  EXPECT_DOUBLE_EQ(decode_foot(f, f.id)->force_n, 0.0) << "contact dropout reads 0 N";

  DeviceImperfections slow;
  slow.latency_s = 0.02;
  Rig late("device-latency", slow);
  late.device.update(standing(20.0), 0.0);
  late.device.reply(0);
  late.device.flush();
  EXPECT_FALSE(late.host->receive(f, 5ms)) << "not due yet";
  std::this_thread::sleep_for(20ms);
  late.device.flush();
  EXPECT_TRUE(late.host->receive(f, 100ms));
}

TEST(RobotDevice, BacklashIsADeadBandOnTheReportedAngle) {
  DeviceImperfections play;
  play.backlash_rad = 0.02;
  Rig rig("device-backlash", play);
  auto reported = [&](double joint) {
    PlantState s = standing(0.0);
    s.legs[kFrontLeft].hip_angle_rad = joint;
    rig.device.update(s, 0.001);
    rig.device.reply(joint_index(kFrontLeft, true));
    can::CanFrame f;
    EXPECT_TRUE(rig.host->receive(f, 100ms));
    return rig.config.hip(kFrontLeft).to_joint_position(mit_decode_reply(f, 0, rig.config.ranges)->position_rad);
  };
  EXPECT_NEAR(reported(0.0), 0.0, 1e-3);
  EXPECT_NEAR(reported(0.008), 0.0, 1e-3) << "inside the play: the encoder does not move";
  EXPECT_NEAR(reported(0.05), 0.04, 1e-3) << "the play taken up: the encoder trails by half of it";
  EXPECT_NEAR(reported(0.045), 0.04, 1e-3) << "reversing: the play opens again";
}

}  // namespace
}  // namespace cpgmatch::robot
