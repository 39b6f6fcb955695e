// Sends each hardware rollout's trace to the optimizer on cpgmatch/rollout_traces, in chunks
// (domain/rollout_trace.hpp), from its own thread: the rollout thread hands a trace over after publishing
// the report and goes on at once, so a report never waits on its trace and the next rollout never waits on
// the network. A trace is unregistered once the optimizer has acknowledged it (or after a bounded wait), so
// the writer's history holds at most the trace being sent.
//
// C++17: built into the agent's DDS shell (idl/CMakeLists.txt says why).
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <mutex>
#include <thread>

#include "cpgmatch/dds/participant.hpp"
#include "cpgmatch/domain/rollout_trace.hpp"

namespace cpgmatch::robot {

class TraceSender {
 public:
  explicit TraceSender(dds::Participant& participant);
  ~TraceSender();  // sends nothing more; the trace being sent is cut off
  TraceSender(const TraceSender&) = delete;
  TraceSender& operator=(const TraceSender&) = delete;

  // Queues a trace and returns at once. At most kMaxQueued wait; past that the oldest waiting one is
  // dropped with a warning (a robot's rollouts take seconds each, its traces far less to send).
  void send(domain::RolloutTrace trace);
  // Waits up to `timeout` until every queued trace was sent and acknowledged (before the agent leaves).
  void drain(std::chrono::milliseconds timeout);

  static constexpr std::size_t kMaxQueued = 4;
  // How long one trace waits for the optimizer's acknowledgement before its instance is let go: a live
  // optimizer acknowledges a 20 s rollout's trace in 0.04-0.06 s (docs/robot_agent.md); one killed stays
  // matched until its lease runs out, and each trace waits this long for it, holding up the next.
  static constexpr std::chrono::seconds kAcknowledgeWait{3};

 private:
  void loop();
  void send_now(const domain::RolloutTrace& trace);

  dds::Writer<msg::RolloutTraceChunk> writer_;
  std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<domain::RolloutTrace> queue_;
  bool busy_ = false;
  bool stop_ = false;
  std::thread thread_;  // last: it uses everything above
};

}  // namespace cpgmatch::robot
