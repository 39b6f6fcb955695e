// A motor controller on the CAN bus, as the agent drives it: one impedance command per control tick
// (position, velocity, gains, feed-forward torque), feedback (position, velocity, torque), enable
// (closed loop), disable (zero torque) and set-zero. Values are on the motor's output shaft, SI units
// (rad, rad/s, N m). Joint-side units (gear ratio, direction, zero offset) are the robot description's
// business, not the protocol's.
//
// Implementations (chosen by name, motor_factory.hpp):
//   mit     MIT / CubeMars AK impedance frames, one reply per command (mit_protocol.hpp)
//   odrive  ODrive CANSimple: position + feed-forward, gains set on the device when they change,
//           feedback in several frames (cyclic encoder estimates, Iq) (odrive_protocol.hpp)
//   moteus  mjbots moteus register frames on CAN-FD, command and query in one frame (moteus_protocol.hpp)
//
// A call may put several frames on the bus (ODrive's gains, its torque request): each appends to a
// FrameSink the caller sized once with max_frames(), so the real-time loop never allocates.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string_view>
#include <vector>

#include "cpgmatch/can/can_frame.hpp"

namespace cpgmatch::robot {

struct MotorCommand {
  double position_rad = 0.0;
  double velocity_rad_s = 0.0;
  double kp_nm_per_rad = 0.0;
  double kd_nm_s_per_rad = 0.0;
  double torque_nm = 0.0;  // feed-forward
};

struct MotorFeedback {
  std::uint32_t node_id = 0;
  double position_rad = 0.0;
  double velocity_rad_s = 0.0;
  double torque_nm = 0.0;
};

enum class FeedbackStatus {
  kOk,           // the frame is this motor's feedback, decoded into `feedback` (see has_*)
  kNotMine,      // another id: somebody else's frame, not an error
  kWrongLength,  // this protocol's feedback id but not its length: a corrupt or foreign frame
  kMalformed,    // this motor's feedback id and length, but contents that do not parse
};

struct FeedbackResult {
  FeedbackStatus status = FeedbackStatus::kNotMine;
  MotorFeedback feedback;
  // Which parts of `feedback` this frame carried: some protocols spread them over several frames.
  bool has_position = false;  // position_rad and velocity_rad_s
  bool has_torque = false;    // torque_nm
  // A fault the device reports about itself (0 = none): an ODrive axis error, a moteus fault code.
  std::uint32_t fault = 0;
  const char* fault_kind = "";  // what `fault` is ("axis error", ...), static text
};

// A fixed buffer of outgoing frames (never allocates after construction).
class FrameSink {
 public:
  explicit FrameSink(std::size_t capacity = 0) : frames_(capacity) {}
  void reserve(std::size_t capacity) { frames_.resize(capacity); }
  // False (and the frame dropped) when full: callers size the sink by max_frames() so it never is.
  bool push(const can::CanFrame& frame) {
    if (count_ >= frames_.size()) return false;
    frames_[count_++] = frame;
    return true;
  }
  void clear() { count_ = 0; }
  std::size_t size() const { return count_; }
  std::span<const can::CanFrame> frames() const { return {frames_.data(), count_}; }
  const can::CanFrame& operator[](std::size_t i) const { return frames_[i]; }

 private:
  std::vector<can::CanFrame> frames_;
  std::size_t count_ = 0;
};

class MotorProtocol {
 public:
  virtual ~MotorProtocol() = default;
  virtual std::string_view name() const = 0;
  virtual std::uint32_t node_id() const = 0;
  // The most frames one command(), enable(), disable() or set_zero() appends.
  virtual std::size_t max_frames() const = 0;
  // Never allocate: called in the real-time loop (and, for the safe state, from the agent's watch thread
  // at the same time, so implementations keep any state they need in atomics).
  virtual void command(const MotorCommand& command, FrameSink& out) = 0;
  virtual void enable(FrameSink& out) = 0;
  virtual void disable(FrameSink& out) = 0;
  virtual void set_zero(FrameSink& out) = 0;
  // Called by the control loop's thread only.
  virtual FeedbackResult decode_feedback(const can::CanFrame& frame) = 0;
  // The receive filters that let this motor's feedback through (appended; construction time).
  virtual void feedback_filters(std::vector<can::CanFilter>& out) const = 0;
  // True when position feedback answers each command (MIT, moteus); false when the device streams it on
  // its own clock (ODrive's cyclic encoder estimates).
  virtual bool answers_commands() const = 0;
  virtual bool needs_fd() const { return false; }
};

}  // namespace cpgmatch::robot
