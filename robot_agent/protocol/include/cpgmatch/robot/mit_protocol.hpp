// The MIT Mini-Cheetah / CubeMars AK "MIT mode" impedance protocol on classic CAN (1 Mbit/s), as in Ben
// Katz's motor-controller firmware (reference notes, section 6.2).
//
// Command, to CAN id = the motor's node id, 8 bytes, big-endian bit packing:
//   p_des 16 bit | v_des 12 bit | kp 12 bit | kd 12 bit | t_ff 12 bit
//   d0 = p>>8, d1 = p&FF, d2 = v>>4, d3 = (v&F)<<4 | kp>>8, d4 = kp&FF, d5 = kd>>4, d6 = (kd&F)<<4 | t>>8, d7 = t&FF
// Reply, to CAN id = the host id (0 by default), 6 bytes:
//   d0 = node id, d1..d2 = p 16 bit, d3 = v>>4, d4 = (v&F)<<4 | t>>8, d5 = t&FF
// Special frames to the node id: FF FF FF FF FF FF FF FC enter motor mode, ...FD exit, ...FE set zero.
//
// Each value maps linearly onto its unsigned integer over [min, max] of its range; values outside are
// clamped (the firmware does the same), NaN becomes 0. The ranges must match the firmware's
// (MitRanges: per motor model; the defaults are the Mini Cheetah's).
#pragma once

#include <cstdint>
#include <optional>

#include "cpgmatch/robot/motor_protocol.hpp"

namespace cpgmatch::robot {

struct MitRanges {
  double position_max_rad = 12.5;      // p in [-max, max]
  double velocity_max_rad_s = 65.0;    // v in [-max, max]
  double kp_max_nm_per_rad = 500.0;    // kp in [0, max]
  double kd_max_nm_s_per_rad = 5.0;    // kd in [0, max]
  double torque_max_nm = 18.0;         // t in [-max, max]
};

inline constexpr int kMitPositionBits = 16;
inline constexpr int kMitVelocityBits = 12;
inline constexpr int kMitGainBits = 12;
inline constexpr int kMitTorqueBits = 12;
inline constexpr std::uint8_t kMitCommandLength = 8;
inline constexpr std::uint8_t kMitReplyLength = 6;

enum class MitSpecial { kEnterMotorMode = 0xFC, kExitMotorMode = 0xFD, kSetZero = 0xFE };

// The linear maps between a value in [low, high] and a `bits`-bit unsigned integer (clamping, rounding).
std::uint32_t mit_float_to_uint(double x, double low, double high, int bits);
double mit_uint_to_float(std::uint32_t u, double low, double high, int bits);

// Host side.
can::CanFrame mit_encode_command(std::uint32_t node_id, const MotorCommand& command, const MitRanges& ranges);
can::CanFrame mit_special_frame(std::uint32_t node_id, MitSpecial which);
// nullopt unless the frame is a 6-byte reply on host_id (data[0] is the node id).
std::optional<MotorFeedback> mit_decode_reply(const can::CanFrame& frame, std::uint32_t host_id, const MitRanges& ranges);

// Motor side (the emulator).
struct MitReceived {
  enum class Kind { kCommand, kEnterMotorMode, kExitMotorMode, kSetZero };
  Kind kind = Kind::kCommand;
  MotorCommand command;  // kCommand only
};
// nullopt for a frame that is not an 8-byte data frame.
std::optional<MitReceived> mit_decode_command(const can::CanFrame& frame, const MitRanges& ranges);
can::CanFrame mit_encode_reply(std::uint32_t host_id, const MotorFeedback& feedback, const MitRanges& ranges);

// One MIT motor on the bus. The single-frame helpers (command(c), enable(), ...) are what the sink
// versions append: exactly one frame each.
class MitMotor final : public MotorProtocol {
 public:
  MitMotor(std::uint32_t node_id, std::uint32_t host_id, const MitRanges& ranges);
  std::string_view name() const override { return "mit"; }
  std::uint32_t node_id() const override { return node_id_; }
  std::size_t max_frames() const override { return 1; }
  can::CanFrame command(const MotorCommand& command) const;
  can::CanFrame enable() const;
  can::CanFrame disable() const;
  can::CanFrame set_zero() const;
  void command(const MotorCommand& c, FrameSink& out) override { out.push(command(c)); }
  void enable(FrameSink& out) override { out.push(enable()); }
  void disable(FrameSink& out) override { out.push(disable()); }
  void set_zero(FrameSink& out) override { out.push(set_zero()); }
  FeedbackResult decode_feedback(const can::CanFrame& frame) override { return decode(frame); }
  FeedbackResult decode(const can::CanFrame& frame) const;
  void feedback_filters(std::vector<can::CanFilter>& out) const override { out.push_back(feedback_filter()); }
  can::CanFilter feedback_filter() const;
  bool answers_commands() const override { return true; }
  const MitRanges& ranges() const { return ranges_; }

 private:
  std::uint32_t node_id_;
  std::uint32_t host_id_;
  MitRanges ranges_;
};

}  // namespace cpgmatch::robot
