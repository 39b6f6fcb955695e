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
          [this](const msg::Candidate& c) {
            const CandidateQueue::Offer offer = queue_.offer(c);  // the queue keeps only ours
            if (offer != CandidateQueue::Offer::kNotOurs) {
              spdlog::debug("worker {}: candidate study {} trial {} attempt {}: {}", config_.worker_id, c.study_id(),
                            c.trial_id(), c.attempt(), CandidateQueue::to_string(offer));
            }
          },
          [this](const msg::Candidate& key, dds::InstanceGone gone) {
            if (gone.disposed) acknowledged(key);  // not on a lost optimizer: its successor needs the reports
          }),
      spec_reader_(participant_, [this](const msg::StudySpecSample& sample) {
        // Kept as received; whoever uses it checks the hash and the version (SpecBook).
        std::lock_guard<std::mutex> lock(specs_mutex_);
        const bool is_new = specs_.count(sample.spec_key()) == 0;
        specs_[sample.spec_key()] = ReceivedSpec{sample.spec_key(), sample.objective_version(),
                                                 sample.sha256().to_string(), sample.spec_json().to_string()};
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
    stops_ = std::make_unique<dds::Reader<msg::EmergencyStop>>(participant_, config_.on_emergency_stop);
  }
}

bool WorkerLink::publish(const msg::RolloutReport& report) {
  std::lock_guard<std::mutex> lock(mutex_);
  const bool written = reports_.write(report);
  spdlog::debug("worker {}: report study {} trial {} attempt {} written (ok {}, cost {})", config_.worker_id,
                report.study_id(), report.trial_id(), report.attempt(), report.ok(), report.cost());
  if (!written) spdlog::error("study {} trial {}: report write failed", report.study_id(), report.trial_id());
  for (const auto& old : kept_.keep(report)) reports_.unregister(old);
  return written;
}

void WorkerLink::acknowledged(const msg::Candidate& key) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (const auto report = kept_.acknowledge(key)) reports_.unregister(*report);
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
  msg::WorkerAnnouncement a;
  a.worker_key(dds::worker_key(config_.worker_id));
  a.worker_id(config_.worker_id);
  a.kind(config_.kind);
  a.host(config_.host);
  a.pid(static_cast<std::uint32_t>(getpid()));
  a.slots(config_.slots);
  a.heartbeat_period_s(config_.heartbeat_s);
  a.accepting(accepting);
  a.status(accepting ? std::string() : status_);
  a.objective_version(config_.objective_version);
  a.busy(load.busy);
  a.completed(load.completed);
  announcements_.write(a);
  last_announcement_ = a;
}

void WorkerLink::heartbeat_until(const std::function<bool()>& stop) {
  using Clock = std::chrono::steady_clock;
  const auto period = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(config_.heartbeat_s));
  auto next = Clock::now();
  bool announced_accepting = true;
  while (!stop()) {
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
}

}  // namespace cpgmatch::worker
