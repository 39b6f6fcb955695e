// CanPlant: the Plant interface (common/include/cpgmatch/plant.hpp) backed by the robot's motor bus, so
// that the very same controller, contact sensing and cost (common/ run_rollout) drive the real robot.
//
// One control period per advance(): send every motor its impedance command (after the limits) in its own
// protocol (a MotorProtocol per joint, from the robot description), collect the motors' feedback and the
// sensor frames, sleep to the absolute deadline, check the watchdog. The loop neither allocates nor locks
// nor logs; faults are written into a fixed buffer.
//
// Safety (docs/robot_agent.md):
// - position targets are clamped to each joint's limits and to where kp x (target - measured) stays
//   within the joint's torque limit; velocities or torques measured beyond the limits trip the watchdog;
// - the watchdog trips when a motor or sensor has been silent for safety.feedback_timeout_s, when the
//   loop misses max_consecutive_overruns deadlines in a row, on a bus-off error frame, or when the
//   loop itself stops ticking (a separate thread watches it); tripping sends every motor the safe state
//   (kp = 0, feed-forward 0, damping) at once and keeps sending it;
// - once tripped, fault() says why and the rollout ends at once as a plant fault (state() also reports a non-finite trunk).
#pragma once

#include <array>
#include <atomic>
#include <memory>
#include <optional>
#include <string>
#include <thread>

#include "cpgmatch/can/can_bus.hpp"
#include "cpgmatch/plant.hpp"
#include <mutex>
#include <vector>

#include "cpgmatch/robot/motor_protocol.hpp"
#include "cpgmatch/robot/realtime.hpp"
#include "cpgmatch/robot/robot_config.hpp"

namespace cpgmatch::robot {

struct LoopStats {
  std::uint64_t ticks = 0;
  double jitter_p50_us = 0.0;  // wake-up lateness after the absolute deadline
  double jitter_p99_us = 0.0;
  double jitter_max_us = 0.0;
  std::uint64_t overruns = 0;
  // Command to feedback: from sending a period's commands until every motor and sensor was heard.
  double feedback_latency_p50_us = 0.0;
  double feedback_latency_p99_us = 0.0;
  double feedback_latency_max_us = 0.0;
  std::uint64_t missing_replies = 0;    // motor replies that did not arrive within their period
  std::uint64_t unexpected_frames = 0;  // frames no motor or sensor claims, or with the wrong length
};

struct CanPlantOptions {
  double enable_timeout_s = 0.2;     // how long prepare() waits for every node to answer
  bool watchdog_thread = true;       // a second thread that makes the motors safe if the loop stalls
  // Lockstep with an emulator: every period waits for all replies (up to the feedback timeout) even
  // past its deadline, so a slow emulator delays the rollout instead of changing it. Never on a robot.
  bool wait_for_every_reply = false;
};

class CanPlant final : public Plant {
 public:
  // Throws InputError when the description's leg count is not the Plant's (RobotConfig::plant_mismatch).
  CanPlant(const RobotConfig& config, can::CanBus& bus, CanPlantOptions options = {});
  ~CanPlant() override;
  CanPlant(const CanPlant&) = delete;
  CanPlant& operator=(const CanPlant&) = delete;

  // Before a rollout of `rollout_s` seconds: enables the motors, waits for every motor and sensor, ramps
  // the joints to the standing pose. Returns the reason when the robot is not ready (then the motors are
  // made safe). After the rollout's last period the plant goes to the safe state by itself.
  std::optional<std::string> prepare(double rollout_s);
  // After a rollout (or on a fall or a signal): safe state, then motor mode off.
  void finish();
  // The Plant lifecycle: activate() is prepare(), deactivate() is finish(); active between a successful
  // prepare() and finish(), in fault once tripped, inactive otherwise.
  std::optional<std::string> activate(double duration_s) override { return prepare(duration_s); }
  void deactivate() override { finish(); }
  PlantLifecycle lifecycle() const override;
  // Trips the watchdog from outside (emergency stop, SIGINT/SIGTERM): safe state at once.
  void emergency_stop(const char* reason);

  void command(const PerLeg<JointCommand>& commands) override;
  void advance(double dt_s) override;
  PlantState state() const override;
  double time_step_s() const override { return period_s_; }

  bool tripped() const { return tripped_.load(std::memory_order_acquire); }
  // True when the rollout saw the fault (a non-finite state) and so ended because of it; a trip after
  // the rollout had ended by itself (a fall, its last period) is not the rollout's failure.
  bool fault_ended_rollout() const { return fault_seen_.load(std::memory_order_acquire); }
  // Why the watchdog tripped, or nullopt.
  std::optional<std::string> fault() const override;
  LoopStats loop_stats() const;
  // When the safe state first went out after a trip, and the last reply of the motor that had been
  // silent longest at that moment (monotonic ns; 0 = never): after a silence the watchdog's reaction
  // time is the difference.
  std::int64_t safe_state_sent_ns() const { return safe_sent_ns_.load(std::memory_order_acquire); }
  std::int64_t silent_since_ns() const { return silent_since_at_trip_ns_.load(std::memory_order_acquire); }
  // The command last sent to a joint (RobotConfig::joints order), motor-shaft units (tests, diagnostics).
  const MotorCommand& last_sent(int joint) const { return sent_[joint]; }
  const MotorProtocol& motor(int joint) const { return *motors_[joint]; }

 private:
  void send_commands();
  void send_safe_state();
  void receive_until(std::int64_t deadline_ns);
  bool handle(const can::CanFrame& frame, std::int64_t now_ns);
  void check_watchdog(std::int64_t now_ns);
  void trip(const char* format, ...) __attribute__((format(printf, 2, 3)));
  bool everything_heard_since(std::int64_t since_ns) const;
  bool all_motors_heard_since(std::int64_t since_ns) const;
  void watch_loop();

  RobotConfig config_;
  can::CanBus& bus_;
  CanPlantOptions options_;
  double period_s_;
  std::int64_t period_ns_;
  std::int64_t timeout_ns_;  // the robot's feedback timeout (the stall watch)
  int joint_count_;
  std::vector<std::unique_ptr<MotorProtocol>> motors_;   // per joint, RobotConfig::joints order
  std::vector<std::int64_t> joint_timeout_ns_;           // per joint feedback timeout
  std::vector<int> hip_of_leg_, knee_of_leg_;            // leg -> joint index
  FrameSink loop_frames_;                                // the control loop's outgoing frames
  FrameSink safe_frames_;                                // the safe state's, from whichever thread trips
  std::mutex safe_mutex_;                                // guards safe_frames_ (only taken on the fault path)

  // Targets (joint units) after the limits, and what went out (motor units).
  PerLeg<JointCommand> targets_{};
  std::vector<MotorCommand> sent_;
  // Latest feedback, joint units, and when position feedback arrived (monotonic ns; 0 = never).
  std::vector<double> position_, velocity_, torque_;
  std::vector<std::int64_t> motor_heard_ns_;
  std::vector<double> foot_force_;
  std::vector<std::int64_t> foot_heard_ns_;
  TrunkState trunk_{};
  std::int64_t trunk_heard_ns_ = 0;
  double time_s_ = 0.0;
  // Silence is counted from when replies were first expected: the first period's commands (motors
  // answer only when commanded, so the time spent preparing is not silence).
  std::int64_t expect_since_ns_ = 0;

  PeriodicTimer timer_;
  JitterStats jitter_;
  JitterStats feedback_latency_;  // the same microsecond histogram, for command-to-feedback times
  int overruns_in_row_ = 0;
  std::uint64_t missing_replies_ = 0;
  std::uint64_t unexpected_frames_ = 0;
  std::uint64_t ticks_ = 0;
  std::uint64_t rollout_ticks_ = 0;  // after this many the rollout is over: safe state, no stall watch

  std::atomic<bool> tripped_{false};
  std::atomic<bool> active_{false};  // between a successful prepare() and finish()
  std::atomic<std::int64_t> safe_sent_ns_{0};
  std::atomic<std::int64_t> silent_since_at_trip_ns_{0};
  mutable std::atomic<bool> fault_seen_{false};
  std::array<char, 256> fault_{};
  // The loop's heartbeat for the watch thread (monotonic ns of the last tick; 0 = not running).
  std::atomic<std::int64_t> heartbeat_ns_{0};
  std::atomic<bool> stop_watch_{false};
  std::thread watch_thread_;
};

}  // namespace cpgmatch::robot
