// Runs rollouts on the robot: the common/ rollout loop against a CanPlant on the motor bus, with the
// safety checks around it. This header is plain C++17 on purpose: the agent's DDS shell includes it, and
// targets with generated DDS types are built as C++17 (idl/CMakeLists.txt); the CAN and plant code
// behind it is C++20.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include "cpgmatch/domain/rollout_trace.hpp"
#include "cpgmatch/params.hpp"
#include "cpgmatch/robot/estop_latch.hpp"
#include "cpgmatch/rollout.hpp"

namespace cpgmatch {
struct RobotDescription;
}  // namespace cpgmatch

namespace cpgmatch::robot {

struct HardwareRunnerOptions {
  std::string can_uri;
  std::string robot_path;
  bool realtime = true;      // SCHED_FIFO + mlockall for the rollout thread when permitted
  int fifo_priority = 80;
  // Emulator in lockstep only (needs an emulator_only robot description): wait for every reply.
  bool lockstep = false;
  // This robot's id: emergency-stop commands name it (or every robot).
  std::string robot_id;
};

struct HardwareLoopStats {
  std::uint64_t ticks = 0;
  double jitter_p50_us = 0.0;
  double jitter_p99_us = 0.0;
  double jitter_max_us = 0.0;
  std::uint64_t overruns = 0;
  double feedback_latency_p50_us = 0.0;  // command sent to every motor and sensor heard
  double feedback_latency_p99_us = 0.0;
  double feedback_latency_max_us = 0.0;
  std::uint64_t missing_replies = 0;
  std::uint64_t unexpected_frames = 0;
};

// Why a hardware rollout did not measure its point, for the optimizer: a refusal (a latched stop) and a
// fault of the robot are re-issued, never spent; an error (parameters outside the robot's envelope, a
// rollout that threw) counts as a failed evaluation.
enum class HardwareOutcome { kRan, kRefused, kPlantFault, kError };

struct HardwareRollout {
  bool ok = false;            // false: refused or stopped by a fault; `error` says why
  HardwareOutcome outcome = HardwareOutcome::kError;
  std::string error;
  RolloutResult result;       // valid when ok
  HardwareLoopStats loop;
  double cpu_s = 0.0;         // the rollout thread's CPU time
  // What the robot did at each control tick (when ok): the first domain::kMaxTraceTicks ticks, recorded
  // into room reserved before the loop starts (no allocation in the loop); the rest only counted.
  domain::MeasuredTrace trace;
  std::uint64_t trace_ticks_dropped = 0;
};

class HardwareRunner {
 public:
  // Opens the bus and loads the robot YAML. Throws InputError for a bad URI or YAML, CanError (a
  // std::runtime_error) when the bus cannot open.
  explicit HardwareRunner(const HardwareRunnerOptions& options);
  ~HardwareRunner();
  HardwareRunner(const HardwareRunner&) = delete;
  HardwareRunner& operator=(const HardwareRunner&) = delete;

  // One rollout: refuses parameters outside the robot's safe envelope, prepares the robot (motors on,
  // ramp to standing), runs the common rollout loop at the robot's control rate, ends in the safe
  // state and motors off. Blocks; call from the thread that should run the real-time loop.
  HardwareRollout run(const CpgParameters& params, const RolloutSettings& settings, std::uint64_t seed);

  // From any thread (signal handling): the running rollout trips at once.
  void emergency_stop(const char* reason);

  // From any thread (the emergency-stop topic): a stop for this robot latches and puts every motor in
  // the safe state at once (the running rollout ends failed, "emergency stop: REASON"); while latched
  // run() refuses every candidate; a release lifts the latch. Other robots' commands change nothing.
  StopOutcome stop_command(const StopRequest& request);
  // The latched stop's reason, or nullopt.
  std::optional<std::string> latched_stop() const;
  // While latched: the refusal every candidate gets (run() gives the same), before anything else is looked at.
  std::optional<HardwareRollout> latched_refusal() const;

  // What was refused when entering real-time mode (empty when granted); set after the first run().
  std::string realtime_warning() const;
  double control_rate_hz() const;
  // The robot description this body is (the hardware file's `robot:`), empty when the file names none.
  std::string robot_description() const;
  int leg_count() const;
  // Why a study of `study_robot` may not run on this body (RobotConfig::study_robot_mismatch), or nullopt.
  std::optional<std::string> study_robot_mismatch(const RobotDescription& study_robot) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace cpgmatch::robot
