// A motor controller on the CAN bus, as the agent drives it: one impedance command per control tick
// (position, velocity, gains, feed-forward torque) answered by one feedback frame (position, velocity,
// torque), plus enable (closed loop), disable (zero torque) and set-zero. Values are on the motor's
// output shaft, SI units (rad, rad/s, N m). Joint-side units (gear ratio, direction, zero offset) are
// the robot description's business, not the protocol's.
//
// MIT / CubeMars AK ("MIT mode") is the implementation (mit_protocol.hpp); ODrive CANSimple (pos +
// feed-forward, feedback by cyclic encoder estimates) or moteus (CAN-FD register frames) would be
// further implementations of this interface.
#pragma once

#include <cstdint>
#include <string_view>

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
  kOk,           // the frame is this motor's feedback, decoded into `feedback`
  kNotMine,      // another id: somebody else's frame, not an error
  kWrongLength,  // this protocol's feedback id but not its length: a corrupt or foreign frame
};

struct FeedbackResult {
  FeedbackStatus status = FeedbackStatus::kNotMine;
  MotorFeedback feedback;
};

class MotorProtocol {
 public:
  virtual ~MotorProtocol() = default;
  virtual std::string_view name() const = 0;
  virtual std::uint32_t node_id() const = 0;
  // Never allocates: called in the real-time loop.
  virtual can::CanFrame command(const MotorCommand& command) const = 0;
  virtual can::CanFrame enable() const = 0;
  virtual can::CanFrame disable() const = 0;
  virtual can::CanFrame set_zero() const = 0;
  virtual FeedbackResult decode_feedback(const can::CanFrame& frame) const = 0;
  // The receive filter that lets this motor's feedback through.
  virtual can::CanFilter feedback_filter() const = 0;
};

}  // namespace cpgmatch::robot
