// ODrive "CANSimple" (ODrive v3 firmware 0.5.x and ODrive Pro/S1 0.6.x; odriverobotics/ODrive
// docs/can-protocol.rst, reference notes 6.1) on classic CAN.
//
// Identifier: 11 bits, node_id << 5 | cmd_id; node ids 0..63, so node n owns ids n*32 .. n*32+31.
// Payloads little-endian, floats IEEE 754 binary32. ODrive works in turns (rev): odrive_rev_to_rad() and
// odrive_rad_to_rev() are the only conversions.
//
//   0x001 Heartbeat        device -> host, cyclic: axis_error u32 | axis_state u8 | 3 flag bytes   (8 B)
//   0x007 Set_Axis_State   host -> device: requested_state u32 (1 IDLE, 8 CLOSED_LOOP_CONTROL)      (4 B)
//   0x009 Encoder_Estimates device -> host, cyclic: pos f32 [rev] | vel f32 [rev/s]                   (8 B)
//   0x00B Set_Controller_Mode host -> device: control_mode u32 (3 position) | input_mode u32 (1 passthrough)
//   0x00C Set_Input_Pos    host -> device: pos f32 [rev] | vel_ff i16 [0.001 rev/s] | torque_ff i16 [0.001 N m]
//   0x00E Set_Input_Torque host -> device: torque f32 [N m]                                         (4 B)
//   0x014 Get_Iq           RTR from the host, answered (or cyclic on 0.6.x): Iq_setpoint f32 | Iq_measured f32 [A]
//   0x018 Clear_Errors     host -> device (1 B: identify = 0; 0.5.x ignores the byte)
//   0x019 Set_Absolute_Position host -> device: pos f32 [rev] (0.6.x; set-zero)
//   0x01A Set_Pos_Gain     host -> device: pos_gain f32 [(rev/s)/rev]                              (4 B)
//   0x01B Set_Vel_Gains    host -> device: vel_gain f32 [N m/(rev/s)] | vel_integrator_gain f32     (8 B)
//
// The impedance law. ODrive's position controller is a cascade: vel_setpoint = pos_gain (pos_setpoint -
// pos) + vel_ff, torque = vel_gain (vel_setpoint - vel) + integrator + torque_ff. With the integrator gain 0
// that is torque = (vel_gain pos_gain) (pos_setpoint - pos) + vel_gain (vel_ff - vel) + torque_ff: the MIT
// law with kp = vel_gain pos_gain and kd = vel_gain. So a command's (kp, kd) become vel_gain = kd (per rev)
// and pos_gain = kp / kd, sent with 0x01A/0x01B only when they change (the gains live in the device, not
// in each command); kp > 0 needs kd > 0 (the robot description checks it). Not mapped: the device's own
// vel_limit and current limit, which clamp on top (set them at or above the joint's limits).
#pragma once

#include <atomic>
#include <cstdint>
#include <optional>

#include "cpgmatch/robot/motor_protocol.hpp"

namespace cpgmatch::robot {

inline constexpr double kPi = 3.14159265358979323846;
constexpr double odrive_rev_to_rad(double rev) { return rev * 2.0 * kPi; }
constexpr double odrive_rad_to_rev(double rad) { return rad / (2.0 * kPi); }

enum OdriveCmd : std::uint32_t {
  kOdriveHeartbeat = 0x001,
  kOdriveSetAxisState = 0x007,
  kOdriveEncoderEstimates = 0x009,
  kOdriveSetControllerMode = 0x00B,
  kOdriveSetInputPos = 0x00C,
  kOdriveSetInputTorque = 0x00E,
  kOdriveGetIq = 0x014,
  kOdriveClearErrors = 0x018,
  kOdriveSetAbsolutePosition = 0x019,
  kOdriveSetPosGain = 0x01A,
  kOdriveSetVelGains = 0x01B,
};
inline constexpr std::uint32_t kOdriveAxisIdle = 1;
inline constexpr std::uint32_t kOdriveAxisClosedLoop = 8;
inline constexpr std::uint32_t kOdriveControlPosition = 3;
inline constexpr std::uint32_t kOdriveInputPassthrough = 1;
inline constexpr std::uint32_t kOdriveMaxNode = 63;
// Set_Input_Pos' int16 feed-forwards: 0.001 rev/s and 0.001 N m per unit, so at most +-32.767 of each.
inline constexpr double kOdriveFeedForwardMax = 32.767;

constexpr std::uint32_t odrive_id(std::uint32_t node, std::uint32_t cmd) { return (node << 5) | (cmd & 0x1F); }

struct OdriveSettings {
  // Converts Iq (A) to torque at the motor shaft: the ODrive's motor.config.torque_constant (8.27 / KV).
  double torque_constant_nm_per_a = 0.0;
  // Ask for Iq with an RTR (0.5.x answers only then); false when the device streams it itself (0.6.x
  // iq_msg_rate_ms) or torque feedback is not wanted.
  bool request_iq = true;
  // ... after every iq_every-th command only, staggered by node id, to spare the bus (1: every command).
  std::uint32_t iq_every = 1;
};

// Little-endian field access shared by the agent side and the emulator's twin.
void odrive_put_f32(can::CanFrame& f, int at, float v);
float odrive_get_f32(const can::CanFrame& f, int at);
void odrive_put_u32(can::CanFrame& f, int at, std::uint32_t v);
std::uint32_t odrive_get_u32(const can::CanFrame& f, int at);

// Host-side frames.
can::CanFrame odrive_set_input_pos(std::uint32_t node, double pos_rad, double vel_ff_rad_s, double torque_ff_nm);
can::CanFrame odrive_set_axis_state(std::uint32_t node, std::uint32_t state);
can::CanFrame odrive_float_frame(std::uint32_t node, std::uint32_t cmd, float a);
can::CanFrame odrive_two_floats(std::uint32_t node, std::uint32_t cmd, float a, float b);

// Device-side frames (the emulator's twin) and the decoded host commands it receives.
can::CanFrame odrive_heartbeat(std::uint32_t node, std::uint32_t axis_error, std::uint32_t axis_state);
can::CanFrame odrive_encoder_estimates(std::uint32_t node, double pos_rad, double vel_rad_s);
can::CanFrame odrive_iq(std::uint32_t node, double iq_setpoint_a, double iq_measured_a);
struct OdriveInputPos {
  double pos_rad = 0.0, vel_ff_rad_s = 0.0, torque_ff_nm = 0.0;
};
// nullopt unless an 8-byte data frame.
std::optional<OdriveInputPos> odrive_decode_input_pos(const can::CanFrame& f);

class OdriveMotor final : public MotorProtocol {
 public:
  OdriveMotor(std::uint32_t node_id, const OdriveSettings& settings);
  std::string_view name() const override { return "odrive"; }
  std::uint32_t node_id() const override { return node_; }
  // Gains (2) + Set_Input_Pos + the Iq request; enable: clear errors, mode, gains (2), axis state.
  std::size_t max_frames() const override { return 5; }
  void command(const MotorCommand& command, FrameSink& out) override;
  void enable(FrameSink& out) override;
  void disable(FrameSink& out) override;
  void set_zero(FrameSink& out) override;
  FeedbackResult decode_feedback(const can::CanFrame& frame) override;
  void feedback_filters(std::vector<can::CanFilter>& out) const override;
  bool answers_commands() const override { return false; }
  // The device gains for an impedance (kp N m/rad, kd N m s/rad): {pos_gain (rev/s)/rev, vel_gain N m/(rev/s)}.
  static std::pair<float, float> gains_for(double kp, double kd);

 private:
  void send_gains(double kp, double kd, FrameSink& out);

  std::uint32_t node_;
  OdriveSettings settings_;
  // The gains last sent (NaN: unknown, send again). Atomics: the watch thread sends the safe state too.
  std::atomic<float> pos_gain_sent_, vel_gain_sent_;
  bool closed_loop_seen_ = false;  // a heartbeat in closed loop since enable(); afterwards IDLE is a fault
  std::atomic<bool> enabled_{false};
  std::atomic<std::uint32_t> commands_{0};
};

}  // namespace cpgmatch::robot
