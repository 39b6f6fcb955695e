#include "cpgmatch/robot/estop_latch.hpp"

namespace cpgmatch::robot {

const char* to_string(StopOutcome outcome) {
  switch (outcome) {
    case StopOutcome::kNotForThisRobot: return "not for this robot";
    case StopOutcome::kLatched: return "stopped and latched";
    case StopOutcome::kAlreadyLatched: return "already stopped";
    case StopOutcome::kReleased: return "released";
    case StopOutcome::kNothingToRelease: return "nothing to release";
  }
  return "?";
}

StopOutcome EstopLatch::apply(const StopRequest& request) {
  // An empty target is not "everyone": a stop must name what it stops, and the sender checks this too.
  if (request.target != kAllRobots && request.target != robot_id_) return StopOutcome::kNotForThisRobot;
  std::lock_guard<std::mutex> lock(mutex_);
  if (request.release) {
    if (!reason_) return StopOutcome::kNothingToRelease;
    reason_.reset();
    return StopOutcome::kReleased;
  }
  if (reason_) return StopOutcome::kAlreadyLatched;
  reason_ = request.reason.empty() ? std::string("no reason given") : request.reason;
  return StopOutcome::kLatched;
}

std::optional<std::string> EstopLatch::reason() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return reason_;
}

}  // namespace cpgmatch::robot
