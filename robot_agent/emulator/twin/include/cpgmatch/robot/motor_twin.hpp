// The device side of each motor protocol: what a real MIT/AK driver, ODrive axis or moteus servo does
// with the frames the agent sends, and what it sends back, so that every protocol is tested agent to
// emulator over a real bus backend. A twin knows its own id space and protocol state (enabled, the gains
// an ODrive holds, the reads a moteus query asked for); the body it drives is RobotDevice's business.
//
//   mit     answers every command, enter/exit motor mode and set-zero with one reply frame
//   odrive  Set_Axis_State 8/1 enables/idles; Set_Pos_Gain/Set_Vel_Gains set the gains later commands use;
//           Set_Input_Pos commands; an RTR Get_Iq is answered; encoder estimates and the heartbeat are
//           cyclic (cyclic(), every control period; the heartbeat every heartbeat_period calls)
//   moteus  a frame writing mode 10 from stopped enables, mode 0 stops; its writes command; its reads are
//           answered in the types asked for when the id asks for a reply
#pragma once

#include <memory>

#include "cpgmatch/robot/motor_protocol.hpp"
#include "cpgmatch/robot/robot_config.hpp"

namespace cpgmatch::robot {

struct TwinInput {
  enum class Kind { kNotMine, kCommand, kEnable, kDisable, kZero, kQuery, kIgnored };
  Kind kind = Kind::kNotMine;
  MotorCommand command;    // kCommand and kEnable (motor units; position NaN: hold where it is)
  bool has_command = false;
  bool reply_owed = false; // the device answers this frame (reply() sends it)
};

class MotorTwin {
 public:
  virtual ~MotorTwin() = default;
  // Applies one frame from the bus to the device's protocol state.
  virtual TwinInput receive(const can::CanFrame& frame) = 0;
  // The frames owed since the last call (a reply, a query's answer, an Iq answer), given the motor's
  // current state (motor units). MIT and moteus: their reply; ODrive: Iq if asked, and after enabling
  // a heartbeat and encoder estimates.
  virtual void reply(const MotorFeedback& state, FrameSink& out) = 0;
  // Frames the device sends on its own clock, called every control period (ODrive's cyclic messages).
  virtual void cyclic(const MotorFeedback& /*state*/, FrameSink& /*out*/) {}
  virtual bool enabled() const = 0;
  static constexpr std::size_t kMaxFrames = 4;  // per reply() or cyclic()
};

// The twin of a joint's protocol (by the joint's `protocol`).
std::unique_ptr<MotorTwin> make_motor_twin(const JointConfig& joint, std::uint32_t host_id);

}  // namespace cpgmatch::robot
