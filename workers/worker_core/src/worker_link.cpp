#include "cpgmatch/worker/worker_link.hpp"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <thread>

#include <spdlog/spdlog.h>

#include "cpgmatch/dds/convert.hpp"

namespace cpgmatch::worker {

WorkerLink::WorkerLink(const WorkerLinkConfig& config, CandidateQueue& queue)
    : config_(config),
      queue_(queue),
      participant_([&] {
        dds::ParticipantConfig c;
        c.domain = config.domain;
        c.name = config.participant_name;
        c.localhost_only = config.localhost_only;
        return c;
      }()),
      reports_(participant_),
      announcements_(participant_),
      candidates_(
          participant_,
          [this](const msg::Candidate& wire) {
            // Every candidate on the domain arrives here: look at the worker id before converting anything.
            if (wire.worker_id() != config_.worker_id) return;
            domain::Candidate c;
            try {
              c = dds::from_wire(wire);
            } catch (const dds::WireError& e) {
              return answer_malformed(wire, e.what());
            }
            const CandidateQueue::Offer offer = queue_.offer(c);
            spdlog::debug("worker {}: candidate study {} trial {} attempt {}: {}", config_.worker_id, c.id.study_id,
                          c.id.trial_id, c.id.attempt, CandidateQueue::to_string(offer));
          },
          [this](const msg::Candidate& key, dds::InstanceGone gone) {
            if (gone.disposed) acknowledged(key);  // not on a lost optimizer: its successor needs the reports
          }),
      spec_reader_(participant_, [this](const msg::StudySpecSample& sample) {
        // Kept as received; whoever uses it checks the hash and the version (SpecBook).
        std::lock_guard<std::mutex> lock(specs_mutex_);
        const bool is_new = specs_.count(sample.spec_key()) == 0;
        specs_[sample.spec_key()] = dds::from_wire(sample);
        if (is_new) {
          spec_order_.push_back(sample.spec_key());
          if (spec_order_.size() > kMaxSpecs) {
            specs_.erase(spec_order_.front());
            spec_order_.pop_front();
          }
        }
        spec_arrived_.notify_all();
      }) {
  if (config_.on_emergency_stop) {
    stops_ = std::make_unique<dds::Reader<msg::EmergencyStop>>(
        participant_, [this](const msg::EmergencyStop& s) { config_.on_emergency_stop(dds::from_wire(s)); });
  }
}

namespace {

// The key fields of a report instance, for unregistering it (the topic is keyed by store, study, trial).
msg::RolloutReport report_key(const domain::AttemptId& id) {
  msg::RolloutReport key;
  key.store_id(id.store_id);
  key.study_id(static_cast<std::uint32_t>(id.study_id));
  key.trial_id(static_cast<std::uint32_t>(id.trial_id));
  return key;
}

}  // namespace

bool WorkerLink::publish(const domain::RolloutReport& report) {
  std::lock_guard<std::mutex> lock(mutex_);
  const bool written = reports_.write(dds::to_wire(report));
  spdlog::debug("worker {}: report study {} trial {} attempt {} written ({}, cost {})", config_.worker_id,
                report.id.study_id, report.id.trial_id, report.id.attempt, domain::to_string(report.outcome),
                report.summary.cost);
  if (!written) spdlog::error("study {} trial {}: report write failed", report.id.study_id, report.id.trial_id);
  for (const auto& old : kept_.keep(report.id)) reports_.unregister(report_key(old));
  return written;
}

void WorkerLink::acknowledged(const msg::Candidate& key) {
  // Ids past INT_MAX were never issued to (or reported by) this worker: nothing kept under them.
  const std::optional<domain::AttemptId> id = dds::attempt_of(key);
  if (!id) return;
  std::lock_guard<std::mutex> lock(mutex_);
  if (const auto report = kept_.acknowledge(*id)) reports_.unregister(report_key(*report));
}

void WorkerLink::answer_malformed(const msg::Candidate& c, const std::string& why) {
  spdlog::warn("worker {}: bad candidate for study {} trial {}: {}", config_.worker_id, c.study_id(), c.trial_id(), why);
  // Answered only when its ids are ones the domain can hold; otherwise no optimizer issued it.
  const std::optional<domain::AttemptId> id = dds::attempt_of(c);
  if (!id) return;
  domain::RolloutReport r;
  r.id = *id;
  r.worker_id = config_.worker_id;
  r.worker_kind = config_.kind;
  r.outcome = domain::Outcome::kError;
  r.error = "bad candidate: " + why;
  publish(r);
}

void WorkerLink::set_accepting(bool accepting, const std::string& status) {
  {
    std::lock_guard<std::mutex> lock(announce_mutex_);
    status_ = status.substr(0, 255);
  }
  accepting_ = accepting;
  announce(accepting);  // now, not at the next heartbeat: the optimizer must stop assigning at once
}

std::optional<ReceivedSpec> WorkerLink::spec(std::uint64_t key, std::chrono::milliseconds wait) {
  std::unique_lock<std::mutex> lock(specs_mutex_);
  if (!spec_arrived_.wait_for(lock, wait, [&] { return specs_.count(key) > 0; })) return std::nullopt;
  return specs_.at(key);
}

void WorkerLink::announce(bool accepting) {
  std::lock_guard<std::mutex> lock(announce_mutex_);
  // The heartbeat read accepting_ before taking the lock: a stop announced meanwhile (set_accepting on a
  // DDS thread) must not be undone by that stale value.
  accepting = accepting && accepting_.load();
  const CandidateQueue::Load load = queue_.load();
  domain::WorkerAnnouncement a;
  a.worker_key = domain::worker_key(config_.worker_id);
  a.worker_id = config_.worker_id;
  a.kind = config_.kind;
  a.host = config_.host;
  a.pid = static_cast<std::uint32_t>(getpid());
  a.slots = static_cast<int>(config_.slots);
  a.heartbeat_period_s = config_.heartbeat_s;
  a.accepting = accepting;
  a.status = accepting ? std::string() : status_;
  a.objective_version = config_.objective_version;
  a.busy = static_cast<int>(load.busy);
  a.completed = load.completed;
  last_announcement_ = dds::to_wire(a);
  announcements_.write(last_announcement_);
}

void WorkerLink::heartbeat_until(const std::function<bool()>& stop) {
  using Clock = std::chrono::steady_clock;
  const auto period = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(config_.heartbeat_s));
  auto next = Clock::now();
  bool announced_accepting = true;
  // The optimizer reads the announcements: no reader matched for a while means none on this domain (not
  // started, or started on another domain, or a DDS-Security mismatch). Said in the log, once per silence.
  auto last_heard = Clock::now();
  bool said_unheard = false;
  while (!stop()) {
    if (announcements_.matched().count() > 0) {
      if (said_unheard) spdlog::info("worker {}: an optimizer is on domain {} now", config_.worker_id, config_.domain);
      last_heard = Clock::now();
      said_unheard = false;
    } else if (!said_unheard && Clock::now() - last_heard > kOptimizerSilence) {
      spdlog::warn("worker {}: no optimizer on DDS domain {} for {} s (none running, another domain, or its "
                   "security settings do not match this worker's)",
                   config_.worker_id, config_.domain,
                   std::chrono::duration_cast<std::chrono::seconds>(kOptimizerSilence).count());
      said_unheard = true;
    }
    const bool accepting = accepting_;
    if (Clock::now() >= next || accepting != announced_accepting) {
      announce(accepting);
      announced_accepting = accepting;
      next = Clock::now() + period;  // after a stall: one announcement now, not a burst to catch up
    }
    std::this_thread::sleep_for(std::min<Clock::duration>(std::chrono::milliseconds(50), next - Clock::now()));
  }
  {
    std::lock_guard<std::mutex> lock(announce_mutex_);
    status_ = "shutting down";
  }
  announce(false);
}

void WorkerLink::leave() {
  // Reliable delivery of the last reports needs a moment before the writer goes away.
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  std::lock_guard<std::mutex> lock(announce_mutex_);
  announcements_.unregister(last_announcement_);
  // The unregister is the worker's goodbye (the optimizer logs a clean leave for it, and re-issues at once);
  // a participant deleted before the optimizer acknowledged it sometimes lost it, and the worker was then
  // declared silent 2.5 s later (integration.two_workers, 1 run in about 20 under a full ctest -j2).
  announcements_.wait_for_acknowledgments(std::chrono::milliseconds(1000));
}

}  // namespace cpgmatch::worker
