// mjbots moteus on CAN-FD (mjbots/moteus docs/reference.md "CAN format", reference notes 6.3).
//
// Arbitration id: 16 bits, source << 8 | destination, plus 0x8000 when the sender asks for a reply; the
// agent is source host_id (0..127), each servo destination 1..127. Sent as 29-bit (extended) CAN-FD frames
// with bit rate switch; replies (id servo << 8 | host) are accepted extended or standard.
//
// Payload: register subframes, back to back, padded with NOP (0x50) to a CAN-FD length:
//   0x00 | 0x04 | 0x08 | 0x0C + n   write n int8 | int16 | int32 | float registers (n = 1..3; n = 0: a
//                                   varuint count follows), then the start register (varuint), the values
//   0x10 | 0x14 | 0x18 | 0x1C + n   read n registers of that type from the start register
//   0x20 | 0x24 | 0x28 | 0x2C + n   reply: n values of that type from the start register
//   0x30 / 0x31                     write / read error: register (varuint), error code (varuint)
//   0x50                            NOP
// Values little-endian; varuints 7 bits per byte, low first, high bit = more. Registers used here:
//   0x000 mode (int: 0 stopped, 1 fault, 10 position), 0x001 position [rev], 0x002 velocity [rev/s],
//   0x003 torque [N m], 0x00F fault code; commands 0x020 position, 0x021 velocity, 0x022 feed-forward
//   torque, 0x023 kp_scale, 0x024 kd_scale; 0x131 set output position exactly (set-zero).
// Integer encodings scale per register (position 0.01 / 0.0001 / 0.00001 rev for int8 / int16 / int32,
// velocity 0.1 / 0.00025 / 0.00001 rev/s, torque 0.5 / 0.01 / 0.001 N m, scales 1/127 / 1/32767 /
// 1/2147483647); the type's minimum means NaN. The agent writes and reads floats (no scaling); replies in
// any type decode.
//
// The impedance law. moteus runs torque = kp_scale kp (p_des - p) + kd_scale kd (v_des - v) + ff with
// kp, kd its own configured servo.pid_position gains; a command carries only the scales in [0, 1]. So the
// robot description names each servo's configured gains (servo_kp_nm_per_rad, servo_kd_nm_s_per_rad:
// moteus' N m/rev x 1/(2 pi)) and a command's (kp, kd) become the scales kp / servo_kp and kd / servo_kd,
// exactly, as long as the joint's gains do not exceed the servo's (checked when the description loads).
#pragma once

#include <array>
#include <cstdint>
#include <optional>

#include "cpgmatch/robot/motor_protocol.hpp"

namespace cpgmatch::robot {

inline constexpr std::uint32_t kMoteusReplyRequested = 0x8000;
inline constexpr std::uint32_t kMoteusMaxId = 127;
enum MoteusRegister : std::uint32_t {
  kMoteusMode = 0x000,
  kMoteusPosition = 0x001,
  kMoteusVelocity = 0x002,
  kMoteusTorque = 0x003,
  kMoteusFault = 0x00F,
  kMoteusCommandPosition = 0x020,
  kMoteusCommandVelocity = 0x021,
  kMoteusCommandTorque = 0x022,
  kMoteusKpScale = 0x023,
  kMoteusKdScale = 0x024,
  kMoteusSetOutputExact = 0x131,
};
inline constexpr int kMoteusModeStopped = 0;
inline constexpr int kMoteusModeFault = 1;
inline constexpr int kMoteusModePosition = 10;
enum class MoteusType : std::uint8_t { kInt8 = 0, kInt16 = 1, kInt32 = 2, kFloat = 3 };

struct MoteusSettings {
  double servo_kp_nm_per_rad = 0.0;   // the servo's configured servo.pid_position.kp, in SI
  double servo_kd_nm_s_per_rad = 0.0; // servo.pid_position.kd, in SI
  std::uint32_t host_id = 0;          // the agent's source id
};

constexpr std::uint32_t moteus_command_id(std::uint32_t host, std::uint32_t servo) {
  return kMoteusReplyRequested | (host << 8) | servo;
}
constexpr std::uint32_t moteus_reply_id(std::uint32_t servo, std::uint32_t host) { return (servo << 8) | host; }

// Register values in SI (rad, rad/s, N m) for one int or float encoding; the NaN code for integers.
double moteus_decode_value(std::uint32_t reg, MoteusType type, std::int64_t raw_int, float raw_float);

// What a servo is told in one frame (the device side parses it; tests check the agent's frames with it).
struct MoteusRequest {
  std::optional<int> mode;
  std::optional<double> position_rad, velocity_rad_s, torque_nm, kp_scale, kd_scale, set_output_rad;
  struct Read {
    std::uint32_t start = 0;
    std::uint32_t count = 0;
    MoteusType type = MoteusType::kFloat;
  };
  std::array<Read, 8> reads{};
  std::size_t read_count = 0;
  bool reply_requested = false;
};
// nullopt for a frame that is not FD or whose subframes do not parse (truncated, unknown opcode).
std::optional<MoteusRequest> moteus_parse_request(const can::CanFrame& frame);

// The servo's state as its reply reports it.
struct MoteusState {
  int mode = kMoteusModeStopped;
  double position_rad = 0.0, velocity_rad_s = 0.0, torque_nm = 0.0;
  int fault = 0;
};
// The reply a servo sends to `request`'s reads (each read answered in its own type); an FD frame.
can::CanFrame moteus_encode_reply(std::uint32_t servo, std::uint32_t host, const MoteusRequest& request,
                                  const MoteusState& state);

class MoteusMotor final : public MotorProtocol {
 public:
  MoteusMotor(std::uint32_t servo_id, const MoteusSettings& settings);
  std::string_view name() const override { return "moteus"; }
  std::uint32_t node_id() const override { return servo_; }
  std::size_t max_frames() const override { return 1; }
  void command(const MotorCommand& command, FrameSink& out) override;
  void enable(FrameSink& out) override;
  void disable(FrameSink& out) override;
  void set_zero(FrameSink& out) override;
  FeedbackResult decode_feedback(const can::CanFrame& frame) override;
  void feedback_filters(std::vector<can::CanFilter>& out) const override;
  bool answers_commands() const override { return true; }
  bool needs_fd() const override { return true; }

 private:
  can::CanFrame frame(int mode, double position_rad, double velocity_rad_s, double torque_nm, double kp_scale,
                      double kd_scale) const;

  std::uint32_t servo_;
  MoteusSettings settings_;
};

}  // namespace cpgmatch::robot
