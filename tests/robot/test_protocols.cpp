// Issue 31's protocols: CAN-FD frames through every bus backend, ODrive CANSimple and moteus encode /
// decode round trips at their range limits, malformed frames rejected, the protocol factory, and a
// CanPlant rollout against the device twins over each protocol (virtual and udp buses).
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <thread>

#include <gtest/gtest.h>

#include "cpgmatch/can/can_bus.hpp"
#include "cpgmatch/can/udp_frame.hpp"
#include "cpgmatch/errors.hpp"
#include "cpgmatch/robot/can_plant.hpp"
#include "cpgmatch/robot/motor_factory.hpp"
#include "cpgmatch/robot/motor_twin.hpp"
#include "cpgmatch/robot/robot_device.hpp"
#include "cpgmatch/rollout.hpp"

namespace cpgmatch::robot {
namespace {

using namespace std::chrono_literals;

can::CanFrame fd_frame(std::uint32_t id, std::uint8_t length, bool extended = true) {
  can::CanFrame f;
  f.id = id;
  f.extended = extended;
  f.fd = true;
  f.bit_rate_switch = true;
  f.length = length;
  for (std::uint8_t i = 0; i < length; ++i) f.data[i] = static_cast<std::uint8_t>(0xA0 + i);
  return f;
}

std::uint16_t free_udp_port() {
  static std::uint16_t next = static_cast<std::uint16_t>(41000 + (::getpid() % 5000));
  return next++;
}

// ---- CAN-FD frames ----

TEST(CanFd, LengthsAndProblems) {
  EXPECT_EQ(can::fd_length_for(9), 12);
  EXPECT_EQ(can::fd_length_for(33), 48);
  EXPECT_EQ(can::fd_length_for(64), 64);
  EXPECT_FALSE(can::frame_problem(fd_frame(0x1FFFFFFF, 64)).has_value());
  EXPECT_NE(can::frame_problem(fd_frame(1, 13)).value_or("").find("not a CAN-FD length"), std::string::npos);
  can::CanFrame remote = fd_frame(1, 0);
  remote.remote = true;
  EXPECT_TRUE(can::frame_problem(remote).has_value());
  can::CanFrame classic = fd_frame(1, 12);
  classic.fd = false;
  classic.bit_rate_switch = false;
  EXPECT_NE(can::frame_problem(classic).value_or("").find("data length 12 is over 8"), std::string::npos);
  EXPECT_EQ(can::to_string(fd_frame(0x123, 2, false)), "123##1A0A1");
}

TEST(CanFd, UdpRecordsRoundTripAndOldRecordsStillRead) {
  std::array<std::uint8_t, can::kUdpFdFrameSize> buffer{};
  for (const std::uint8_t length : {0, 8, 12, 48, 64}) {
    const can::CanFrame f = fd_frame(0x8001, length);
    ASSERT_EQ(can::encode_udp_record(f, buffer), can::kUdpFdFrameSize);
    EXPECT_EQ(buffer[5], can::kWireFdFlag | can::kWireBrsFlag);
    std::size_t consumed = 0;
    const auto back = can::decode_udp_record(buffer, consumed);
    ASSERT_TRUE(back.has_value());
    EXPECT_EQ(consumed, can::kUdpFdFrameSize);
    EXPECT_EQ(*back, f) << can::to_string(f);
  }
  // A version-1 record (byte 5 = 0) is a classic frame, 16 bytes.
  const std::array<std::uint8_t, 16> v1{0, 0, 0x01, 0x23, 2, 0, 0, 0, 0xDE, 0xAD};
  std::size_t consumed = 0;
  const auto classic = can::decode_udp_record(v1, consumed);
  ASSERT_TRUE(classic.has_value());
  EXPECT_FALSE(classic->fd);
  EXPECT_EQ(consumed, 16u);
  // Malformed: an FD record cut short, an FD length that is no DLC, unknown flags.
  std::size_t used = 0;
  const char* why = nullptr;
  can::encode_udp_record(fd_frame(1, 64), buffer);
  EXPECT_FALSE(can::decode_udp_record(std::span<const std::uint8_t>(buffer.data(), 40), used, &why).has_value());
  EXPECT_STREQ(why, "truncated CAN-FD frame record");
  buffer[4] = 13;
  EXPECT_FALSE(can::decode_udp_record(buffer, used, &why).has_value());
  buffer[4] = 8;
  buffer[5] = 0x80;
  EXPECT_FALSE(can::decode_udp_record(buffer, used, &why).has_value());
  EXPECT_STREQ(why, "unknown flags");
}

// FD and classic frames mixed in one batch, through the virtual and the udp backend.
TEST(CanFd, FramesCrossEveryBusBackend) {
  const std::vector<can::CanFrame> frames{fd_frame(0x8001, 64), fd_frame(0x100, 12, false), fd_frame(0x0100, 32)};
  std::vector<can::CanFrame> batch = frames;
  can::CanFrame classic;
  classic.id = 0x7FF;
  classic.length = 8;
  classic.data[7] = 0x42;
  batch.insert(batch.begin() + 1, classic);
  const std::string udp = "udp:127.0.0.1:" + std::to_string(free_udp_port());
  for (const std::string& uri : {std::string("virtual:fd"), udp}) {
    auto device = can::open_can_bus(uri, can::BusRole::kDevice);
    auto controller = can::open_can_bus(uri, can::BusRole::kController);
    controller->send(batch);
    for (const can::CanFrame& expected : batch) {
      can::CanFrame got;
      ASSERT_TRUE(device->receive(got, 1s)) << uri;
      EXPECT_EQ(got, expected) << uri << ": " << can::to_string(got);
    }
    device->send(frames[0]);  // and back
    can::CanFrame got;
    ASSERT_TRUE(controller->receive(got, 1s)) << uri;
    EXPECT_EQ(got, frames[0]);
  }
}

// SocketCAN stays real code: here (no AF_CAN) it fails with the reason, FD or not.
TEST(CanFd, SocketCanFailsClearlyWithoutAfCan) {
  try {
    auto bus = can::open_can_bus("socketcan:vcan0");
    // A kernel with SocketCAN but no FD interface: sending FD must say why.
    EXPECT_THROW(bus->send(fd_frame(1, 64)), can::CanError);
  } catch (const can::CanError& e) {
    const std::string what = e.what();
    EXPECT_TRUE(what.find("this kernel has no SocketCAN (AF_CAN)") != std::string::npos ||
                what.find("no network interface") != std::string::npos) << what;
  }
}

// ---- ODrive CANSimple ----

TEST(Odrive, IdsAreNodeShiftedFiveAndTurnsConvertOnce) {
  EXPECT_EQ(odrive_id(1, kOdriveSetInputPos), 0x2Cu);  // the docs' example
  EXPECT_EQ(odrive_id(63, 0x1F), 0x7FFu);
  EXPECT_NEAR(odrive_rev_to_rad(odrive_rad_to_rev(1.2345)), 1.2345, 1e-15);
  EXPECT_NEAR(odrive_rev_to_rad(1.0), 2.0 * kPi, 1e-15);
  EXPECT_THROW(OdriveMotor(64, {0.05, true}), std::invalid_argument);
}

TEST(Odrive, SetInputPosBytesAndRoundTripAtTheLimits) {
  // 1 rev, vel_ff 1 rev/s (1000), torque_ff -2 N m (-2000), little-endian.
  const can::CanFrame f = odrive_set_input_pos(3, 2.0 * kPi, 2.0 * kPi, -2.0);
  EXPECT_EQ(f.id, 0x6Cu);
  EXPECT_EQ(f.length, 8);
  const std::array<std::uint8_t, 8> expected{0x00, 0x00, 0x80, 0x3F, 0xE8, 0x03, 0x30, 0xF8};
  EXPECT_TRUE(std::equal(expected.begin(), expected.end(), f.data.begin()));
  // The int16 feed-forwards saturate at +-32.767; positions are floats (float precision).
  for (const double pos : {-1000.0, -0.001, 0.0, 3.3, 1000.0}) {
    for (const double ff : {-40.0, -32.767, 0.0, 12.345, 32.767, 40.0}) {
      const auto back = odrive_decode_input_pos(odrive_set_input_pos(3, pos, odrive_rev_to_rad(ff), ff));
      ASSERT_TRUE(back.has_value());
      EXPECT_NEAR(back->pos_rad, pos, std::abs(pos) * 1e-7 + 1e-9);
      const double clamped = std::clamp(ff, -32.768, 32.767);
      EXPECT_NEAR(odrive_rad_to_rev(back->vel_ff_rad_s), clamped, 0.0005 + 1e-9);
      EXPECT_NEAR(back->torque_ff_nm, clamped, 0.0005 + 1e-9);
    }
  }
  const auto nan = odrive_decode_input_pos(odrive_set_input_pos(3, 0.0, NAN, NAN));
  EXPECT_EQ(nan->vel_ff_rad_s, 0.0);
}

TEST(Odrive, ImpedanceBecomesDeviceGainsOnlyWhenTheyChange) {
  OdriveMotor motor(2, {0.05, true});
  FrameSink sink(motor.max_frames());
  motor.enable(sink);
  ASSERT_EQ(sink.size(), 5u);  // clear errors, controller mode, pos gain 0, vel gains 0, closed loop
  EXPECT_EQ(sink[0].id, odrive_id(2, kOdriveClearErrors));
  EXPECT_EQ(odrive_get_u32(sink[1], 0), kOdriveControlPosition);
  EXPECT_EQ(odrive_get_f32(sink[2], 0), 0.0f);
  EXPECT_EQ(odrive_get_u32(sink[4], 0), kOdriveAxisClosedLoop);
  MotorCommand c;
  c.position_rad = 1.0;
  c.kp_nm_per_rad = 40.0;
  c.kd_nm_s_per_rad = 0.5;
  sink.clear();
  motor.command(c, sink);
  ASSERT_EQ(sink.size(), 4u);  // pos gain, vel gains, input pos, Iq request
  EXPECT_FLOAT_EQ(odrive_get_f32(sink[0], 0), 80.0f);                         // kp / kd, 1/s
  EXPECT_FLOAT_EQ(odrive_get_f32(sink[1], 0), static_cast<float>(0.5 * 2 * kPi));  // N m/(rev/s)
  EXPECT_EQ(odrive_get_f32(sink[1], 4), 0.0f);                                // no integrator
  EXPECT_EQ(sink[2].id, odrive_id(2, kOdriveSetInputPos));
  EXPECT_TRUE(sink[3].remote);
  EXPECT_EQ(sink[3].id, odrive_id(2, kOdriveGetIq));
  sink.clear();
  c.position_rad = 1.1;
  motor.command(c, sink);
  EXPECT_EQ(sink.size(), 2u) << "same gains: only the position and the Iq request";
  // The twin turns the gains back into the impedance the plant asked for.
  JointConfig joint;
  joint.protocol = "odrive";
  joint.node_id = 2;
  joint.odrive = {0.05, true};
  auto twin = make_motor_twin(joint, 0);
  FrameSink both(2 * motor.max_frames());
  motor.enable(both);
  motor.command(c, both);
  TwinInput last;
  for (const can::CanFrame& f : both.frames()) {
    const TwinInput in = twin->receive(f);
    if (in.kind == TwinInput::Kind::kCommand) last = in;
  }
  EXPECT_TRUE(twin->enabled());
  EXPECT_NEAR(last.command.kp_nm_per_rad, 40.0, 1e-4);
  EXPECT_NEAR(last.command.kd_nm_s_per_rad, 0.5, 1e-6);
  EXPECT_NEAR(last.command.position_rad, 1.1, 1e-6);
}

TEST(Odrive, FeedbackArrivesInPartsAndMalformedFramesAreRejected) {
  OdriveMotor motor(5, {0.04, true});
  const FeedbackResult estimates = motor.decode_feedback(odrive_encoder_estimates(5, -3.0, 12.0));
  EXPECT_EQ(estimates.status, FeedbackStatus::kOk);
  EXPECT_TRUE(estimates.has_position);
  EXPECT_FALSE(estimates.has_torque);
  EXPECT_NEAR(estimates.feedback.position_rad, -3.0, 1e-6);
  EXPECT_NEAR(estimates.feedback.velocity_rad_s, 12.0, 1e-5);
  const FeedbackResult iq = motor.decode_feedback(odrive_iq(5, 10.0, 25.0));
  EXPECT_TRUE(iq.has_torque);
  EXPECT_FALSE(iq.has_position);
  EXPECT_NEAR(iq.feedback.torque_nm, 1.0, 1e-6);  // 25 A x 0.04 N m/A
  // Another node, a command id of this node, an extended id: not feedback.
  EXPECT_EQ(motor.decode_feedback(odrive_encoder_estimates(6, 0, 0)).status, FeedbackStatus::kNotMine);
  EXPECT_EQ(motor.decode_feedback(odrive_set_input_pos(5, 0, 0, 0)).status, FeedbackStatus::kNotMine);
  can::CanFrame ext = odrive_encoder_estimates(5, 0, 0);
  ext.extended = true;
  EXPECT_EQ(motor.decode_feedback(ext).status, FeedbackStatus::kNotMine);
  // Wrong length, NaN contents.
  can::CanFrame short_frame = odrive_encoder_estimates(5, 1, 1);
  short_frame.length = 6;
  EXPECT_EQ(motor.decode_feedback(short_frame).status, FeedbackStatus::kWrongLength);
  EXPECT_EQ(motor.decode_feedback(odrive_encoder_estimates(5, NAN, 0)).status, FeedbackStatus::kMalformed);
  // Heartbeats: an axis error is a fault; leaving closed loop after having been in it is one too.
  EXPECT_EQ(motor.decode_feedback(odrive_heartbeat(5, 0x40, kOdriveAxisIdle)).fault, 0x40u);
  FrameSink sink(motor.max_frames());
  motor.enable(sink);
  EXPECT_EQ(motor.decode_feedback(odrive_heartbeat(5, 0, kOdriveAxisIdle)).fault, 0u) << "not yet in closed loop";
  EXPECT_EQ(motor.decode_feedback(odrive_heartbeat(5, 0, kOdriveAxisClosedLoop)).fault, 0u);
  const FeedbackResult left = motor.decode_feedback(odrive_heartbeat(5, 0, kOdriveAxisIdle));
  EXPECT_EQ(left.fault, kOdriveAxisIdle);
  EXPECT_STREQ(left.fault_kind, "axis left closed loop, now in state");
}

// ---- moteus ----

TEST(Moteus, CommandFrameLayout) {
  MoteusMotor motor(5, {50.0, 1.0, 0});
  FrameSink sink(1);
  MotorCommand c{2.0 * kPi, 0.0, 25.0, 0.5, -1.5};
  motor.command(c, sink);
  const can::CanFrame f = sink[0];
  EXPECT_EQ(f.id, 0x8005u);  // reply requested | source 0 << 8 | servo 5
  EXPECT_TRUE(f.extended);
  EXPECT_TRUE(f.fd);
  EXPECT_EQ(f.length, 32);   // 3 + 23 + 2 + 2 + 2 bytes of subframes: exactly a CAN-FD length
  // write int8 x1 @0x000 = 10 (position mode); write float x5 @0x020; reads.
  const std::array<std::uint8_t, 6> head{0x01, 0x00, 0x0A, 0x0C, 0x05, 0x20};
  EXPECT_TRUE(std::equal(head.begin(), head.end(), f.data.begin()));
  EXPECT_EQ(f.data[26], 0x1F);  // read float x3 @0x001
  EXPECT_EQ(f.data[27], 0x01);
  EXPECT_EQ(f.data[30], 0x11);  // read int8 x1 @0x00F, the fault code
  EXPECT_EQ(f.data[31], 0x0F);
  sink.clear();
  motor.disable(sink);
  EXPECT_EQ(sink[0].length, 12);  // mode 0 and the reads (9 bytes), padded with NOPs
  EXPECT_EQ(sink[0].data[11], 0x50);
  const auto request = moteus_parse_request(f);
  ASSERT_TRUE(request.has_value());
  EXPECT_EQ(request->mode, kMoteusModePosition);
  EXPECT_NEAR(*request->position_rad, 2.0 * kPi, 1e-6);
  EXPECT_NEAR(*request->kp_scale, 0.5, 1e-7);   // 25 / 50
  EXPECT_NEAR(*request->kd_scale, 0.5, 1e-7);   // 0.5 / 1
  EXPECT_NEAR(*request->torque_nm, -1.5, 1e-6);
  EXPECT_TRUE(request->reply_requested);
  EXPECT_EQ(request->read_count, 3u);
}

TEST(Moteus, ScalesClampToTheServosGainsAndRoundTripAtTheLimits) {
  MoteusMotor motor(127, {50.0, 1.0, 127});
  FrameSink sink(1);
  for (const MotorCommand& c : {MotorCommand{-1e4, -500.0, 0.0, 0.0, -100.0}, MotorCommand{1e4, 500.0, 50.0, 1.0, 100.0},
                                MotorCommand{0.1, 0.2, 80.0, 3.0, 0.3}}) {
    sink.clear();
    motor.command(c, sink);
    const auto r = moteus_parse_request(sink[0]);
    ASSERT_TRUE(r.has_value());
    EXPECT_EQ(sink[0].id, 0xFF7Fu);
    EXPECT_NEAR(*r->position_rad, c.position_rad, std::abs(c.position_rad) * 1e-7);
    EXPECT_NEAR(*r->velocity_rad_s, c.velocity_rad_s, std::abs(c.velocity_rad_s) * 1e-7);
    EXPECT_NEAR(*r->torque_nm, c.torque_nm, 1e-6);
    EXPECT_NEAR(*r->kp_scale, std::min(c.kp_nm_per_rad / 50.0, 1.0), 1e-7);
    EXPECT_NEAR(*r->kd_scale, std::min(c.kd_nm_s_per_rad / 1.0, 1.0), 1e-7);
  }
  EXPECT_THROW(MoteusMotor(128, {50.0, 1.0, 0}), std::invalid_argument);
  EXPECT_THROW(MoteusMotor(0, {50.0, 1.0, 0}), std::invalid_argument);
}

// Replies decode in every integer type with its scaling (and NaN codes), as a servo may answer.
TEST(Moteus, RepliesDecodeInEveryTypeAtTheRangeLimits) {
  MoteusMotor motor(3, {50.0, 1.0, 0});
  MoteusState state;
  state.mode = kMoteusModePosition;
  state.position_rad = 2.0 * kPi * 3.2767;   // int16: 32767 x 0.0001 rev, the largest
  state.velocity_rad_s = -2.0 * kPi * 8.19175;  // int16: -32767 x 0.00025 rev/s
  state.torque_nm = 327.67;                  // int16: 32767 x 0.01 N m
  const std::array<std::pair<MoteusType, double>, 4> types{{{MoteusType::kInt8, 0.5}, {MoteusType::kInt16, 0.01},
                                                            {MoteusType::kInt32, 0.001}, {MoteusType::kFloat, 1e-4}}};
  for (const auto& [type, torque_step] : types) {
    MoteusRequest request;
    request.reads[0] = {kMoteusPosition, 3, type};
    request.reads[1] = {kMoteusMode, 1, MoteusType::kInt8};
    request.read_count = 2;
    const can::CanFrame reply = moteus_encode_reply(3, 0, request, state);
    EXPECT_EQ(reply.id, 0x0300u);
    const FeedbackResult r = motor.decode_feedback(reply);
    ASSERT_EQ(r.status, FeedbackStatus::kOk) << static_cast<int>(type);
    ASSERT_TRUE(r.has_position && r.has_torque);
    if (type == MoteusType::kInt8) {  // saturates at 127 x 0.01 rev, 127 x 0.1 rev/s, 127 x 0.5 N m
      EXPECT_NEAR(r.feedback.position_rad, 2.0 * kPi * 1.27, 1e-9);
      EXPECT_NEAR(r.feedback.velocity_rad_s, -2.0 * kPi * 8.19175, 2.0 * kPi * 0.05 + 1e-9);
      EXPECT_NEAR(r.feedback.torque_nm, 63.5, 1e-9);
    } else {
      EXPECT_NEAR(r.feedback.position_rad, state.position_rad, 2.0 * kPi * 0.00005 + 1e-5);
      EXPECT_NEAR(r.feedback.velocity_rad_s, state.velocity_rad_s, 2.0 * kPi * 0.000125 + 1e-5);
      EXPECT_NEAR(r.feedback.torque_nm, state.torque_nm, torque_step / 2 + 1e-4);
    }
  }
  // NaN codes: the type's minimum.
  can::CanFrame nan_reply;
  nan_reply.id = 0x0300;
  nan_reply.extended = true;
  nan_reply.fd = true;
  nan_reply.length = 8;
  const std::array<std::uint8_t, 8> bytes{0x26, 0x01, 0x00, 0x80, 0x00, 0x00, 0x50, 0x50};  // reply int16 x2 @1: NaN, 0
  std::copy(bytes.begin(), bytes.end(), nan_reply.data.begin());
  EXPECT_FALSE(motor.decode_feedback(nan_reply).has_position);
}

TEST(Moteus, MalformedAndForeignFramesAreRejected) {
  MoteusMotor motor(3, {50.0, 1.0, 0});
  MoteusRequest request;
  request.reads[0] = {kMoteusPosition, 3, MoteusType::kFloat};
  request.read_count = 1;
  can::CanFrame reply = moteus_encode_reply(3, 0, request, MoteusState{});
  can::CanFrame other = reply;
  other.id = 0x0400;
  EXPECT_EQ(motor.decode_feedback(other).status, FeedbackStatus::kNotMine);
  can::CanFrame classic = reply;
  classic.fd = false;
  classic.length = 8;
  EXPECT_EQ(motor.decode_feedback(classic).status, FeedbackStatus::kWrongLength);
  can::CanFrame truncated = reply;
  truncated.length = 8;  // the three floats cut after the first
  EXPECT_EQ(motor.decode_feedback(truncated).status, FeedbackStatus::kMalformed);
  can::CanFrame unknown = reply;
  unknown.data[0] = 0x77;
  EXPECT_EQ(motor.decode_feedback(unknown).status, FeedbackStatus::kMalformed);
  // A servo in fault mode with its code.
  MoteusState faulted;
  faulted.mode = kMoteusModeFault;
  faulted.fault = 33;
  request.reads[1] = {kMoteusMode, 1, MoteusType::kInt8};
  request.reads[2] = {kMoteusFault, 1, MoteusType::kInt8};
  request.read_count = 3;
  const FeedbackResult r = motor.decode_feedback(moteus_encode_reply(3, 0, request, faulted));
  EXPECT_EQ(r.fault, 33u);
  // The twin ignores frames that do not parse and answers only when asked.
  JointConfig joint;
  joint.protocol = "moteus";
  joint.node_id = 3;
  joint.moteus = {50.0, 1.0, 0};
  auto twin = make_motor_twin(joint, 0);
  FrameSink sink(1);
  motor.command(MotorCommand{}, sink);
  can::CanFrame broken = sink[0];
  broken.data[0] = 0x2F;  // a reply opcode in a request
  EXPECT_EQ(twin->receive(broken).kind, TwinInput::Kind::kIgnored);
  EXPECT_EQ(twin->receive(sink[0]).kind, TwinInput::Kind::kEnable);
  EXPECT_EQ(twin->receive(sink[0]).kind, TwinInput::Kind::kCommand);
}

TEST(MotorFactory, ChoosesByName) {
  ProtocolSettings s;
  s.odrive.torque_constant_nm_per_a = 0.05;
  s.moteus.servo_kp_nm_per_rad = 1.0;
  for (const std::string_view name : kMotorProtocols) EXPECT_EQ(make_motor_protocol(name, 1, s)->name(), name);
  EXPECT_TRUE(make_motor_protocol("moteus", 1, s)->needs_fd());
  EXPECT_FALSE(make_motor_protocol("odrive", 1, s)->answers_commands());
  EXPECT_THROW(make_motor_protocol("canopen", 1, s), std::invalid_argument);
}

// ---- A rollout on the CanPlant against the device twins, per protocol ----

// A device side answering like the emulator does in real time: what each twin owes at once, the sensors
// and cyclic messages every control period.
class TwinRobot {
 public:
  TwinRobot(const RobotConfig& config, const std::string& uri)
      : bus_(can::open_can_bus(uri, can::BusRole::kDevice)), device_(config, *bus_), period_ns_(std::llround(1e9 / config.control_rate_hz)) {
    thread_ = std::thread([this] { run(); });
  }
  ~TwinRobot() {
    stop_ = true;
    thread_.join();
  }
  int commands() const { return commands_; }

 private:
  void run() {
    std::int64_t next = 0;
    while (!stop_) {
      const auto got = device_.receive(200us);
      if (got.event == RobotDevice::Event::kCommand) ++commands_;
      PlantState s;
      s.legs = PerLeg<LegState>(device_.joint_commands().size());
      s.trunk.height_m = 0.25;
      for (std::size_t leg = 0; leg < s.legs.size(); ++leg) {
        s.legs[leg].hip_angle_rad = device_.joint_commands()[leg].hip_angle_rad;
        s.legs[leg].knee_flexion_rad = device_.joint_commands()[leg].knee_flexion_rad;
        s.legs[leg].hip_torque_nm = 0.5;
        s.legs[leg].foot_normal_force_n = 10.0;
      }
      device_.update(s, 0.0);
      if (got.reply_owed) device_.reply(got.joint);
      if (monotonic_ns() >= next) {
        device_.send_sensors();
        next = monotonic_ns() + period_ns_;
      }
    }
  }
  std::unique_ptr<can::CanBus> bus_;
  RobotDevice device_;
  std::int64_t period_ns_;
  std::atomic<bool> stop_{false};
  std::atomic<int> commands_{0};
  std::thread thread_;
};

RobotConfig tolerant(RobotConfig c) {
  c.safety.max_consecutive_overruns = 100;
  c.safety.feedback_timeout_s = 0.5;  // this machine is shared: the protocol path is under test here
  for (JointConfig& j : c.joints) j.feedback_timeout_s.reset();
  return c;
}

RobotConfig shipped(const std::string& name) {
  return load_robot_config(std::filesystem::path(default_robot_config_path()).parent_path().string() + "/" + name);
}

// Morti's joints moved onto moteus servos (ids 1..8, the servo's gains above the joints').
RobotConfig moteus_quadruped() {
  RobotConfig c = shipped("morti.yaml");
  for (JointConfig& j : c.joints) {
    j.protocol = "moteus";
    j.moteus = {50.0, 1.0, c.host_id};
  }
  return c;
}

struct ProtocolCase {
  const char* name;
  RobotConfig (*config)();
  const char* bus;
};

class ProtocolRollout : public ::testing::TestWithParam<ProtocolCase> {};

TEST_P(ProtocolRollout, RunsACommonRolloutAndEndsInTheSafeState) {
  const ProtocolCase& p = GetParam();
  const RobotConfig config = tolerant(p.config());
  const std::string uri = std::string(p.bus) == "udp" ? "udp:127.0.0.1:" + std::to_string(free_udp_port())
                                                      : std::string("virtual:rollout-") + p.name;
  TwinRobot robot(config, uri);
  auto bus = can::open_can_bus(uri, can::BusRole::kController);
  CanPlant plant(config, *bus, {0.2, false});
  EXPECT_EQ(plant.motor(0).name(), config.joints[0].protocol);
  RolloutSettings settings;
  settings.entrain_s = 0.2;
  settings.eval_s = 0.3;
  settings.controller.control_rate_hz = config.control_rate_hz;
  ASSERT_EQ(plant.prepare(settings.entrain_s + settings.eval_s), std::nullopt);
  const RolloutResult result = run_rollout(plant, CpgParameters{}, settings, 1);
  EXPECT_FALSE(plant.fault_ended_rollout()) << plant.fault().value_or("");
  EXPECT_FALSE(result.fell);
  const auto ticks = static_cast<std::uint64_t>(std::llround(0.5 * config.control_rate_hz));
  EXPECT_EQ(plant.loop_stats().ticks, ticks);
  // Every joint commanded every period (the last period's frames may still be on their way).
  EXPECT_GE(robot.commands(), static_cast<int>(ticks - 1) * config.joint_count());
  // The joints followed the CPG: the plant read back positions that moved, in its protocol.
  const PlantState s = plant.state();
  EXPECT_GT(std::abs(s.legs[0].hip_angle_rad) + std::abs(s.legs[1].hip_angle_rad), 1e-3);
  // Torque came back too (ODrive: through Get_Iq): the scripted hip torque, 0.5 N m.
  EXPECT_NEAR(s.legs[0].hip_torque_nm, 0.5, 0.02);
  plant.finish();
}

INSTANTIATE_TEST_SUITE_P(EachProtocol, ProtocolRollout,
                         ::testing::Values(ProtocolCase{"odrive_virtual", [] { return shipped("odrive-quadruped.yaml"); }, "virtual"},
                                           ProtocolCase{"odrive_udp", [] { return shipped("odrive-quadruped.yaml"); }, "udp"},
                                           ProtocolCase{"moteus_virtual", moteus_quadruped, "virtual"},
                                           ProtocolCase{"moteus_udp", moteus_quadruped, "udp"},
                                           ProtocolCase{"mit_udp", [] { return shipped("morti.yaml"); }, "udp"}),
                         [](const auto& param_info) { return std::string(param_info.param.name); });

// The hexapod's description loads and its CanPlant carries six legs (the Plant is N-legged).
TEST(ProtocolRollout, TheHexapodsPlantHasSixLegs) {
  const RobotConfig hexapod = shipped("moteus-hexapod.yaml");
  auto bus = can::open_can_bus("virtual:hexapod");
  CanPlant plant(hexapod, *bus, {0.2, false});
  EXPECT_EQ(plant.state().legs.size(), 6u);
}

}  // namespace
}  // namespace cpgmatch::robot
