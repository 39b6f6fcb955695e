// The read-only ROS 2 view of the studies an optimizer runs (docs/ros2.md): what it publishes natively on
// cpgmatch/*, again under ROS 2's names and types, so that `ros2 topic echo /cpgmatch/study_state` works:
//
//   rt/cpgmatch/study_state  cpgmatch_msgs::msg::dds_::StudyState_   reliable, transient local, KEEP_LAST 1
//   rt/cpgmatch/trials       cpgmatch_msgs::msg::dds_::TrialRecord_  reliable, transient local, KEEP_LAST 100000
//   rt/cpgmatch/workers      cpgmatch_msgs::msg::dds_::Worker_       reliable, volatile, KEEP_LAST 16
//
// ROS 2 types are unkeyed: one DDS instance per topic. A single transient-local writer of KEEP_LAST 1 would
// hand a late subscriber the state of whichever study changed last. So each study gets its own writer on
// the state and trials topics: a late subscriber matches all of them and gets the latest state of every
// study, and every trial of it. A finished study's writers go when its trial records leave the native
// topic (the coordinator's retire_trial, a grace period after it ends); a study that was already closed
// when the service started is not shown.
//
// Worker announcements are republished at each heartbeat the optimizer hears (volatile: every live worker
// shows within one heartbeat period; history would show workers long gone), and once with alive = false.
//
// Type information for eProsima DDS Record & Replay is opt-in (announce_types): the writers then announce
// their types (XTypes TypeInformation) and the participant must answer TypeLookup requests
// (ParticipantConfig::serve_type_lookup), so the recorder stores each topic with its type. It is off by
// default because Cyclone DDS 0.10, and with it ROS 2 nodes on rmw_cyclonedds, refuses Fast DDS 2.9's
// TypeInformation and drops the writer (docs/ros2.md).
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "cpgmatch/domain/study_state.hpp"
#include "cpgmatch/domain/worker_announcement.hpp"
#include "cpgmatch/dds/participant.hpp"

namespace cpgmatch::dds {

class Ros2View {
 public:
  // Throws when a topic cannot be created (e.g. a DDS-Security enclave not permitted to publish rt/ topics).
  Ros2View(Participant& participant, bool announce_types);
  ~Ros2View();
  Ros2View(const Ros2View&) = delete;
  Ros2View& operator=(const Ros2View&) = delete;

  // Each returns false when the DDS write failed (the caller says so; the view never stops the service).
  bool publish_state(const domain::StudyState& state);
  bool publish_trial(const domain::TrialRecord& record);
  // The study's trials and its state leave the view (its writers are deleted).
  void retire_study(int study_id);
  bool publish_worker(const domain::WorkerAnnouncement& announcement);
  // A worker left or fell silent: its last announcement once more, with alive = false.
  bool worker_gone(std::uint64_t worker_key);
  // The id of the worker last heard under `worker_key` ("" when none was).
  std::string worker_id_of(std::uint64_t worker_key) const;

  static constexpr const char* kStateTopic = "rt/cpgmatch/study_state";
  static constexpr const char* kTrialsTopic = "rt/cpgmatch/trials";
  static constexpr const char* kWorkersTopic = "rt/cpgmatch/workers";
  static constexpr int kWorkersDepth = 16;
  // A study's trials writer keeps this many (the largest budget a study file may ask for).
  static constexpr int kMaxTrialsDepth = 100000;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace cpgmatch::dds
