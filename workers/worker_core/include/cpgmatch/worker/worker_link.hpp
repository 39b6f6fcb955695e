// A worker's DDS side, shared by cpgmatch-sim-worker and cpgmatch-robot-agent: its participant, the
// candidates addressed to it (into a CandidateQueue), its reports (kept until the optimizer
// acknowledges them, see kept_reports.hpp) and its heartbeats. What a worker does with a candidate is
// the program's own business.
//
//   CandidateQueue queue(id);
//   WorkerLink link(WorkerLinkConfig{...}, queue);
//   rollout thread: while (auto c = queue.take()) { link.publish(run(*c)); queue.finish(*c); }
//   main thread:    link.heartbeat_until([] { return g_stop != 0; }); queue.drain(); join; link.leave();
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include "cpgmatch/dds/participant.hpp"
#include "cpgmatch/domain/command.hpp"
#include "cpgmatch/domain/study_state.hpp"
#include "cpgmatch/worker/candidate_queue.hpp"
#include "cpgmatch/worker/kept_reports.hpp"

namespace cpgmatch::worker {

struct WorkerLinkConfig {
  int domain = 0;
  std::string worker_id;         // unique on the domain; the candidates addressed to it are kept
  std::string participant_name;  // what other participants see (logs, peer discovery)
  bool localhost_only = false;
  domain::WorkerKind kind = domain::WorkerKind::kSimulation;
  std::uint32_t slots = 1;       // announced capacity
  double heartbeat_s = 0.5;
  std::string host;              // announced host name
  // Robot agents only: emergency-stop commands (cpgmatch/estop), called on a DDS thread. Unset: no
  // reader, so a simulation worker never subscribes.
  std::function<void(const domain::EmergencyStop&)> on_emergency_stop;
  // The objective version this worker computes (study::kObjectiveVersion), announced with every heartbeat.
  int objective_version = 0;
  // No optimizer heard for a while (30 s, doubling to 120 s, each times a random factor in [0.5, 1.5)): leave
  // the domain and join again with a new participant, unless reports wait for acknowledgement in the old
  // one (heartbeat_until says what it tries). Off where others hold the participant (robot agent traces).
  bool rejoin_when_unheard = false;
};

// A study spec as received on cpgmatch/study_specs (study_spec.hpp says what is in it), not yet checked.
using ReceivedSpec = domain::SpecPublication;

class WorkerLink {
 public:
  // Joins the domain; candidates start arriving in `queue` at once.
  WorkerLink(const WorkerLinkConfig& config, CandidateQueue& queue);
  ~WorkerLink();
  WorkerLink(const WorkerLink&) = delete;
  WorkerLink& operator=(const WorkerLink&) = delete;

  // Writes a report and keeps it until the optimizer disposes its candidate. False: the write failed.
  bool publish(const domain::RolloutReport& report);

  // One announcement: id, kind, capacity, and the queue's load.
  void announce(bool accepting);

  // False while the worker must not be given work (a latched emergency stop), with the reason in words:
  // announced at once from the calling thread, so the optimizer stops assigning to it; the heartbeats
  // carry it from then on.
  void set_accepting(bool accepting, const std::string& status = "");

  // The spec with this key, waiting up to `wait` for it to arrive (a candidate and its study's spec travel
  // on two topics, so the candidate can come first); nothing when it did not arrive in time.
  std::optional<ReceivedSpec> spec(std::uint64_t key, std::chrono::milliseconds wait);

  // How long a worker hears no optimizer before it says so in its log (and, with rejoin_when_unheard,
  // about how long before its first rebuild).
  static constexpr std::chrono::seconds kOptimizerSilence{10};
  // Announces every heartbeat period until `stop` returns true (checked every 50 ms, so a signal is
  // acted on quickly), then once more as not accepting. Rebuilds the participant when unheard (config).
  void heartbeat_until(const std::function<bool()>& stop);

  // The link's participant, for a worker's own topics (the robot agent's rollout traces). Valid for the
  // link's life only without rejoin_when_unheard.
  dds::Participant& participant();

  // After the rollouts have ended: gives reliable delivery of the last reports a moment, then leaves the
  // workers topic (the optimizer re-issues whatever was still assigned to this worker).
  void leave();

 private:
  struct Endpoints;
  void received(const msg::Candidate& wire);
  void received(const msg::StudySpecSample& sample);
  void acknowledged(const msg::Candidate& key);
  // A candidate addressed to this worker that the domain cannot hold (a parameter named twice): answered
  // with an error report, so the optimizer learns at once instead of at the lease's end.
  void answer_malformed(const msg::Candidate& c, const std::string& why);
  // How long the `attempt`-th rebuild waits for an optimizer first (jittered).
  static std::chrono::milliseconds rejoin_after(int attempt);
  // Replaces the participant and every endpoint; false (and the old ones kept) when that fails.
  bool rebuild();
  // An optimizer hears this worker (see heartbeat_until).
  bool heard() const;

  WorkerLinkConfig config_;
  CandidateQueue& queue_;
  std::mutex mutex_;  // the report writer and `kept_`: a dispose may arrive while a report is written
  KeptReports kept_;
  msg::WorkerAnnouncement last_announcement_;
  std::atomic<bool> accepting_{true};
  std::mutex announce_mutex_;  // announcements come from the heartbeat thread and from set_accepting()
  std::string status_;         // guarded by announce_mutex_
  // Specs received, by key; the oldest leave past kMaxSpecs (a spec is about 10 kB).
  static constexpr std::size_t kMaxSpecs = 256;
  std::mutex specs_mutex_;
  std::condition_variable spec_arrived_;
  std::map<std::uint64_t, ReceivedSpec> specs_;
  std::deque<std::uint64_t> spec_order_;
  // Last: the readers' callbacks use everything above, so they must be created after and destroyed first.
  // Replaced only by the heartbeat thread (rebuild), under mutex_ and announce_mutex_.
  std::unique_ptr<Endpoints> endpoints_;
};

}  // namespace cpgmatch::worker
