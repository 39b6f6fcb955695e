// The MIT/AK impedance protocol and the sensor frames: exact bytes, round trips at the range limits,
// clamping, and rejection of frames with the wrong length or id.
#include <algorithm>
#include <cmath>

#include <gtest/gtest.h>

#include "cpgmatch/robot/mit_protocol.hpp"
#include "cpgmatch/robot/sensor_protocol.hpp"

namespace cpgmatch::robot {
namespace {

const MitRanges kRanges{};  // p +-12.5, v +-65, kp 0..500, kd 0..5, t +-18

// The first N data bytes of a frame (its array holds 64, for CAN-FD).
template <std::size_t N>
std::array<std::uint8_t, N> first_bytes(const can::CanFrame& f) {
  std::array<std::uint8_t, N> out{};
  std::copy_n(f.data.begin(), N, out.begin());
  return out;
}

// Half a quantisation step of each field: the worst round-trip error.
double half_step(double span, int bits) { return 0.5 * span / ((1 << bits) - 1) + 1e-12; }

TEST(MitProtocol, CommandBytesFollowTheBitPacking) {
  // Mid-range everything: p = 0x8000-ish, v = 0x800-ish; pick exact codes instead.
  MotorCommand c;
  c.position_rad = -12.5;  // 0x0000
  c.velocity_rad_s = 65.0; // 0xFFF
  c.kp_nm_per_rad = 0.0;   // 0x000
  c.kd_nm_s_per_rad = 5.0; // 0xFFF
  c.torque_nm = -18.0;     // 0x000
  const can::CanFrame f = mit_encode_command(3, c, kRanges);
  EXPECT_EQ(f.id, 3u);
  EXPECT_EQ(f.length, 8);
  const std::array<std::uint8_t, 8> expected{0x00, 0x00, 0xFF, 0xF0, 0x00, 0xFF, 0xF0, 0x00};
  EXPECT_EQ(first_bytes<8>(f), expected);
}

TEST(MitProtocol, CommandRoundTripsAtTheLimitsAndInside) {
  const std::vector<MotorCommand> commands{
      {-12.5, -65.0, 0.0, 0.0, -18.0}, {12.5, 65.0, 500.0, 5.0, 18.0}, {0.0, 0.0, 40.0, 0.6, 0.0},
      {1.234, -3.21, 123.4, 1.1, -7.7}, {-0.001, 0.05, 499.9, 4.99, 17.9}};
  for (const MotorCommand& c : commands) {
    const auto back = mit_decode_command(mit_encode_command(1, c, kRanges), kRanges);
    ASSERT_TRUE(back.has_value());
    if (c.position_rad == 12.5 && c.torque_nm == 18.0 && c.kp_nm_per_rad == 500.0) {
      // All at maximum would alias the special frames; the encoder steps p down by one code.
      EXPECT_EQ(back->kind, MitReceived::Kind::kCommand);
      EXPECT_NEAR(back->command.position_rad, 12.5, 25.0 / 65535 + 1e-9);
      continue;
    }
    ASSERT_EQ(back->kind, MitReceived::Kind::kCommand);
    EXPECT_NEAR(back->command.position_rad, c.position_rad, half_step(25.0, 16));
    EXPECT_NEAR(back->command.velocity_rad_s, c.velocity_rad_s, half_step(130.0, 12));
    EXPECT_NEAR(back->command.kp_nm_per_rad, c.kp_nm_per_rad, half_step(500.0, 12));
    EXPECT_NEAR(back->command.kd_nm_s_per_rad, c.kd_nm_s_per_rad, half_step(5.0, 12));
    EXPECT_NEAR(back->command.torque_nm, c.torque_nm, half_step(36.0, 12));
  }
}

TEST(MitProtocol, OutOfRangeValuesClampAndNanIsZero) {
  MotorCommand c{100.0, -1000.0, 9999.0, -1.0, std::nan("")};
  const auto back = mit_decode_command(mit_encode_command(1, c, kRanges), kRanges);
  ASSERT_TRUE(back.has_value());
  EXPECT_DOUBLE_EQ(back->command.position_rad, 12.5);
  EXPECT_DOUBLE_EQ(back->command.velocity_rad_s, -65.0);
  EXPECT_DOUBLE_EQ(back->command.kp_nm_per_rad, 500.0);
  EXPECT_DOUBLE_EQ(back->command.kd_nm_s_per_rad, 0.0);
  EXPECT_NEAR(back->command.torque_nm, 0.0, half_step(36.0, 12));
}

TEST(MitProtocol, NoCommandAliasesASpecialFrame) {
  const can::CanFrame f = mit_encode_command(1, {12.5, 65.0, 500.0, 5.0, 18.0}, kRanges);
  EXPECT_NE(f, mit_special_frame(1, MitSpecial::kEnterMotorMode));
  EXPECT_EQ(mit_decode_command(f, kRanges)->kind, MitReceived::Kind::kCommand);
}

TEST(MitProtocol, SpecialFramesRoundTrip) {
  MitMotor motor(5, 0, kRanges);
  const can::CanFrame enter = motor.enable();
  EXPECT_EQ(enter.id, 5u);
  const std::array<std::uint8_t, 8> bytes{0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFC};
  EXPECT_EQ(first_bytes<8>(enter), bytes);
  EXPECT_EQ(mit_decode_command(enter, kRanges)->kind, MitReceived::Kind::kEnterMotorMode);
  EXPECT_EQ(mit_decode_command(motor.disable(), kRanges)->kind, MitReceived::Kind::kExitMotorMode);
  EXPECT_EQ(mit_decode_command(motor.set_zero(), kRanges)->kind, MitReceived::Kind::kSetZero);
  EXPECT_EQ(motor.disable().data[7], 0xFD);
  EXPECT_EQ(motor.set_zero().data[7], 0xFE);
}

TEST(MitProtocol, ReplyRoundTripsAtTheLimits) {
  MitMotor motor(7, 0, kRanges);
  for (const MotorFeedback& fb : {MotorFeedback{7, -12.5, -65.0, -18.0}, MotorFeedback{7, 12.5, 65.0, 18.0},
                                  MotorFeedback{7, 0.3, -2.0, 1.5}}) {
    const can::CanFrame f = mit_encode_reply(0, fb, kRanges);
    EXPECT_EQ(f.length, 6);
    EXPECT_EQ(f.data[0], 7);
    const FeedbackResult r = motor.decode_feedback(f);
    ASSERT_EQ(r.status, FeedbackStatus::kOk);
    EXPECT_EQ(r.feedback.node_id, 7u);
    EXPECT_NEAR(r.feedback.position_rad, fb.position_rad, half_step(25.0, 16));
    EXPECT_NEAR(r.feedback.velocity_rad_s, fb.velocity_rad_s, half_step(130.0, 12));
    EXPECT_NEAR(r.feedback.torque_nm, fb.torque_nm, half_step(36.0, 12));
  }
  const MotorFeedback clamped = *mit_decode_reply(mit_encode_reply(0, {7, 99.0, -99.0, 99.0}, kRanges), 0, kRanges);
  EXPECT_DOUBLE_EQ(clamped.position_rad, 12.5);
  EXPECT_DOUBLE_EQ(clamped.velocity_rad_s, -65.0);
  EXPECT_DOUBLE_EQ(clamped.torque_nm, 18.0);
}

TEST(MitProtocol, ReplyBitPackingSharesByteFour) {
  // v = 0xABC, t = 0x123: d3 = 0xAB, d4 = 0xC1, d5 = 0x23.
  can::CanFrame f;
  f.id = 0;
  f.length = 6;
  f.data = {9, 0x80, 0x00, 0xAB, 0xC1, 0x23, 0, 0};
  const MotorFeedback fb = *mit_decode_reply(f, 0, kRanges);
  EXPECT_NEAR(fb.velocity_rad_s, mit_uint_to_float(0xABC, -65.0, 65.0, 12), 1e-12);
  EXPECT_NEAR(fb.torque_nm, mit_uint_to_float(0x123, -18.0, 18.0, 12), 1e-12);
  EXPECT_NEAR(fb.position_rad, mit_uint_to_float(0x8000, -12.5, 12.5, 16), 1e-12);
}

TEST(MitProtocol, WrongLengthAndWrongIdAreRejected) {
  MitMotor motor(7, 0, kRanges);
  can::CanFrame reply = mit_encode_reply(0, {7, 0.1, 0.2, 0.3}, kRanges);
  can::CanFrame short_reply = reply;
  short_reply.length = 5;
  EXPECT_EQ(motor.decode_feedback(short_reply).status, FeedbackStatus::kWrongLength);
  can::CanFrame long_reply = reply;
  long_reply.length = 8;
  EXPECT_EQ(motor.decode_feedback(long_reply).status, FeedbackStatus::kWrongLength);
  can::CanFrame other_motor = mit_encode_reply(0, {8, 0.1, 0.2, 0.3}, kRanges);
  EXPECT_EQ(motor.decode_feedback(other_motor).status, FeedbackStatus::kNotMine);
  can::CanFrame other_host = mit_encode_reply(0x10, {7, 0.1, 0.2, 0.3}, kRanges);
  EXPECT_EQ(motor.decode_feedback(other_host).status, FeedbackStatus::kNotMine);
  can::CanFrame extended = reply;
  extended.extended = true;
  EXPECT_EQ(motor.decode_feedback(extended).status, FeedbackStatus::kNotMine);
  EXPECT_FALSE(mit_decode_reply(short_reply, 0, kRanges).has_value());
  // The motor side ignores commands that are not 8 bytes.
  can::CanFrame short_command = mit_encode_command(7, {}, kRanges);
  short_command.length = 7;
  EXPECT_FALSE(mit_decode_command(short_command, kRanges).has_value());
}

TEST(MitProtocol, FilterPassesRepliesOnTheHostId) {
  MitMotor motor(7, 0x00, kRanges);
  EXPECT_TRUE(motor.feedback_filter().matches(mit_encode_reply(0, {7, 0, 0, 0}, kRanges)));
  EXPECT_FALSE(motor.feedback_filter().matches(motor.command({})));
  EXPECT_THROW(MitMotor(0, 0, kRanges), std::invalid_argument);
  EXPECT_THROW(MitMotor(256, 0, kRanges), std::invalid_argument);
}

TEST(SensorProtocol, FootRoundTripsAndClamps) {
  const can::CanFrame f = encode_foot(0x31, {12.34, 200, true});
  const FootReading r = *decode_foot(f, 0x31);
  EXPECT_NEAR(r.force_n, 12.34, 0.005 + 1e-12);
  EXPECT_EQ(r.sequence, 200);
  EXPECT_TRUE(r.fault);
  EXPECT_NEAR(decode_foot(encode_foot(0x31, {1e6, 0, false}), 0x31)->force_n, 655.35, 1e-9);
  EXPECT_DOUBLE_EQ(decode_foot(encode_foot(0x31, {-5.0, 0, false}), 0x31)->force_n, 0.0);
  EXPECT_FALSE(decode_foot(f, 0x32).has_value());
  can::CanFrame wrong = f;
  wrong.length = 3;
  EXPECT_FALSE(decode_foot(wrong, 0x31).has_value());
}

TEST(SensorProtocol, TrunkRoundTripsAndClamps) {
  const TrunkReading pose{-3.21, 0.456, 0.2345};
  const TrunkReading back = *decode_trunk_pose(encode_trunk_pose(0x40, pose), 0x40);
  EXPECT_NEAR(back.x_m, pose.x_m, 0.5e-5 + 1e-12);
  EXPECT_NEAR(back.pitch_rad, pose.pitch_rad, 0.5e-4 + 1e-12);
  EXPECT_NEAR(back.height_m, pose.height_m, 0.5e-5 + 1e-12);
  EXPECT_NEAR(*decode_trunk_speed(encode_trunk_speed(0x40, -0.345), 0x40), -0.345, 0.5e-3 + 1e-12);
  const TrunkReading clamped = *decode_trunk_pose(encode_trunk_pose(0x40, {1e9, 10.0, -1.0}), 0x40);
  EXPECT_NEAR(clamped.x_m, 2147483647 * 1e-5, 1e-6);
  EXPECT_NEAR(clamped.pitch_rad, 3.2767, 1e-9);
  EXPECT_DOUBLE_EQ(clamped.height_m, 0.0);
  EXPECT_FALSE(decode_trunk_pose(encode_trunk_speed(0x40, 1.0), 0x40).has_value());
  EXPECT_FALSE(decode_trunk_speed(encode_trunk_pose(0x40, pose), 0x40).has_value());
}

}  // namespace
}  // namespace cpgmatch::robot
