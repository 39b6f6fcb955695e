// The robot's side of the bus: the motors (each answering in its joint's protocol, through its device
// twin, motor_twin.hpp) and the foot and trunk sensor nodes a RobotConfig describes, around a body that
// supplies the measurements (the ODE Morti in the emulator, a scripted body in tests). It decodes what the
// motors are told into the Plant's joint commands and answers as the motors and sensors would, with
// optional imperfections (noise, lost frames, contact dropouts, latency) so that a sim2real gap can be
// produced on purpose.
#pragma once

#include <chrono>
#include <cstdint>
#include <deque>
#include <memory>
#include <random>
#include <vector>

#include "cpgmatch/can/can_bus.hpp"
#include "cpgmatch/plant.hpp"
#include "cpgmatch/robot/can_plant.hpp"
#include "cpgmatch/robot/motor_twin.hpp"
#include "cpgmatch/robot/robot_config.hpp"

namespace cpgmatch::robot {

struct DeviceImperfections {
  double position_noise_rad = 0.0;   // Gaussian, on every motor position reply (joint units)
  double foot_noise_n = 0.0;         // Gaussian, on every foot force frame
  double contact_dropout = 0.0;      // probability that a foot frame reports 0 N
  double reply_dropout = 0.0;        // probability that a motor reply is lost
  double latency_s = 0.0;            // every frame leaves this much later (flush() sends what is due)
  // Gear play between the motor's encoder and the joint: the reported angle follows the joint only once
  // the play is taken up (a dead band of this total width, joint units).
  double backlash_rad = 0.0;
  std::uint64_t seed = 1;
};

class RobotDevice {
 public:
  // Throws InputError when the description's leg count is not the Plant's (RobotConfig::plant_mismatch).
  RobotDevice(const RobotConfig& config, can::CanBus& bus, DeviceImperfections imperfections = {});

  enum class Event { kNone, kCommand, kEnable, kDisable, kZero, kQuery, kIgnored };
  struct Received {
    Event event = Event::kNone;
    int joint = -1;
    bool reply_owed = false;  // the motor answers this frame: reply(joint)
  };
  // Takes at most one frame (waiting up to `timeout`) and applies it to the motors' state.
  Received receive(std::chrono::nanoseconds timeout);

  // What the motors are doing, in the Plant's terms: targets of enabled motors; a hip whose motor is
  // off or told kp = kd = 0 is passive; a knee whose motor is off keeps its last target.
  const PerLeg<JointCommand>& joint_commands() const { return commands_; }
  int joint_count() const { return static_cast<int>(joints_.size()); }
  bool enabled(int joint) const { return twins_[joint]->enabled(); }
  // Every motor has been commanded since the last clear_commanded() (lockstep stepping).
  bool all_commanded() const;
  void clear_commanded() { std::fill(commanded_.begin(), commanded_.end(), false); }
  // The last impedance command a joint received, motor-shaft units (tests read the safe state here).
  const MotorCommand& last_command(int joint) const { return last_command_[joint]; }
  std::int64_t last_command_ns(int joint) const { return last_command_ns_[joint]; }

  // The motor driver's own command watchdog, as real drivers have one: an enabled motor that has not been
  // commanded for `timeout_ns` goes to the safe state by itself (kp = 0, no torque, damping only; a hip is
  // then passive) and stays there until a new command. A silent controller (crashed, unplugged, its
  // bus down) never leaves the motors holding their last stiff target. Returns the motors it just made safe.
  int enforce_command_timeout(std::int64_t now_ns, std::int64_t timeout_ns);
  bool timed_out(int joint) const { return timed_out_[joint]; }

  // New body measurements; joint velocities come from the change since the previous update.
  void update(const PlantState& state, double dt_s);
  void reply(int joint);     // what one motor owes (its reply, a query's answer), as after its command
  void reply_all();
  // Every control period: the foot and trunk frames, and what motors stream on their own (ODrive's
  // cyclic encoder estimates and heartbeat).
  void send_sensors();
  void flush();              // sends delayed frames that are due (latency_s > 0)

 private:
  void emit(const can::CanFrame& frame);
  void emit_all(const FrameSink& frames, bool motor_feedback);
  double gaussian(double sigma);
  MotorFeedback motor_state(int joint);

  RobotConfig config_;
  can::CanBus& bus_;
  DeviceImperfections imperfections_;
  std::vector<const JointConfig*> joints_;
  std::vector<std::unique_ptr<MotorTwin>> twins_;
  std::vector<bool> commanded_;
  std::vector<MotorCommand> last_command_;
  std::vector<std::int64_t> last_command_ns_;
  std::vector<bool> timed_out_;  // made safe by the command watchdog, until the next command
  std::vector<double> zero_;     // motor position at the last set-zero
  PerLeg<JointCommand> commands_{};
  PlantState state_{};
  std::vector<double> position_, velocity_, torque_;
  std::vector<double> encoder_;  // the motor side of the gear play
  bool have_state_ = false;
  std::uint8_t sequence_ = 0;
  std::mt19937_64 rng_;
  FrameSink out_{MotorTwin::kMaxFrames};
  struct Delayed {
    std::int64_t due_ns;
    can::CanFrame frame;
  };
  std::deque<Delayed> delayed_;
};

}  // namespace cpgmatch::robot
