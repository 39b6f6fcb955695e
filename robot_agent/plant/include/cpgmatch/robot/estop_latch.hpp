// The emergency-stop latch: which stop commands concern this robot, and whether it is stopped now.
// No DDS and no bus here (the agent's DDS shell hands commands over, the runner acts on the outcome), so
// the rule can be tested alone. Plain C++17: the agent's C++17 DDS shell includes it through the runner.
//
// Latched on purpose: safety practice for machines expects a stop to hold until someone releases it
// deliberately, not to lapse when the next candidate arrives. A restart of the agent also clears it
// (the topic is volatile; docs/robot_agent.md).
#pragma once

#include <mutex>
#include <optional>
#include <string>

namespace cpgmatch::robot {

struct StopRequest {
  std::string target;   // a robot (worker) id, or kAllRobots
  std::string reason;   // empty: "no reason given"
  bool release = false; // true: lift the latch
};

inline constexpr const char* kAllRobots = "*";

enum class StopOutcome {
  kNotForThisRobot,   // another robot's stop or release
  kLatched,           // stopped now
  kAlreadyLatched,    // stopped before; the first reason stays (it is what tripped the motors)
  kReleased,          // no longer stopped
  kNothingToRelease,  // a release while not stopped
};

const char* to_string(StopOutcome outcome);

class EstopLatch {
 public:
  explicit EstopLatch(std::string robot_id) : robot_id_(std::move(robot_id)) {}

  // Thread-safe: commands arrive on a DDS thread while the rollout thread asks reason().
  StopOutcome apply(const StopRequest& request);
  // The latched stop's reason, or nullopt when not stopped.
  std::optional<std::string> reason() const;
  const std::string& robot_id() const { return robot_id_; }

 private:
  const std::string robot_id_;
  mutable std::mutex mutex_;
  std::optional<std::string> reason_;
};

}  // namespace cpgmatch::robot
