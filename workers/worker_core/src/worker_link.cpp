#include "cpgmatch/worker/worker_link.hpp"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <random>
#include <thread>
#include <utility>

#include <fmt/format.h>

#include <spdlog/spdlog.h>

#include "cpgmatch/dds/convert.hpp"

namespace cpgmatch::worker {

// Everything this worker has on the domain: built whole, and replaced whole by rebuild().
struct WorkerLink::Endpoints {
  Endpoints(WorkerLink& link, const WorkerLinkConfig& config)
      : participant([&] {
          dds::ParticipantConfig c;
          c.domain = config.domain;
          c.name = config.participant_name;
          c.localhost_only = config.localhost_only;
          return c;
        }()),
        reports(participant),
        announcements(participant),
        candidates(
            participant, dds::Reader<msg::Candidate>::AddressedToWorker{config.worker_id},
            [&link](const msg::Candidate& wire) { link.received(wire); },
            [&link](const msg::Candidate& key, dds::InstanceGone gone) {
              if (gone.disposed) link.acknowledged(key);  // not on a lost optimizer: its successor needs the reports
            }),
        specs(participant, [&link](const msg::StudySpecSample& sample) { link.received(sample); }) {
    if (config.on_emergency_stop) {
      stops = std::make_unique<dds::Reader<msg::EmergencyStop>>(
          participant, [&config](const msg::EmergencyStop& s) { config.on_emergency_stop(dds::from_wire(s)); });
    }
  }
  dds::Participant participant;
  dds::Writer<msg::RolloutReport> reports;
  dds::Writer<msg::WorkerAnnouncement> announcements;
  // Last: the readers' callbacks use the writers, so they must be created after and destroyed first.
  // The candidates addressed to this worker and their disposes (the optimizer's acknowledgement of a
  // report), filtered on the optimizer's side by worker id (worker_filter.hpp, docs/dds.md): what a worker
  // receives does not grow with the fleet.
  dds::Reader<msg::Candidate> candidates;
  dds::Reader<msg::StudySpecSample> specs;
  std::unique_ptr<dds::Reader<msg::EmergencyStop>> stops;
};

WorkerLink::WorkerLink(const WorkerLinkConfig& config, CandidateQueue& queue)
    : config_(config), queue_(queue), endpoints_(std::make_unique<Endpoints>(*this, config_)) {}

WorkerLink::~WorkerLink() = default;

void WorkerLink::received(const msg::Candidate& wire) {
  // The optimizer's writer filters on the worker id (worker_filter.hpp); a writer that does not know the
  // filter class (another vendor's) sends everything, and Fast DDS filters in this reader then. Checked
  // once more before converting anything: the filter passes what it cannot read.
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
}

void WorkerLink::received(const msg::StudySpecSample& sample) {
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
}

dds::Participant& WorkerLink::participant() { return endpoints_->participant; }

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
  const bool written = endpoints_->reports.write(dds::to_wire(report));
  spdlog::debug("worker {}: report study {} trial {} attempt {} written ({}, cost {})", config_.worker_id,
                report.id.study_id, report.id.trial_id, report.id.attempt, domain::to_string(report.outcome),
                report.summary.cost);
  if (!written) spdlog::error("study {} trial {}: report write failed", report.id.study_id, report.id.trial_id);
  for (const auto& old : kept_.keep(report.id)) endpoints_->reports.unregister(report_key(old));
  return written;
}

void WorkerLink::acknowledged(const msg::Candidate& key) {
  // Ids past INT_MAX were never issued to (or reported by) this worker: nothing kept under them.
  const std::optional<domain::AttemptId> id = dds::attempt_of(key);
  if (!id) return;
  std::lock_guard<std::mutex> lock(mutex_);
  if (const auto report = kept_.acknowledge(*id)) endpoints_->reports.unregister(report_key(*report));
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
  endpoints_->announcements.write(last_announcement_);
}

std::chrono::milliseconds WorkerLink::rejoin_after(int attempt) {
  // 30, 60, 120, 120 ... s, each times a factor drawn from [0.5, 1.5): a fleet started in the same second
  // and silent for the same reason (an overloaded discovery server, ports taken) does not retry in step.
  // Not sooner: 200 workers started at once on a loaded 2-core host took up to 2.5 min to be introduced,
  // and workers that rebuilt after 5-15 s only added to the discovery server's work.
  static thread_local std::mt19937 random(std::random_device{}());
  const double base_s = std::min(120.0, 3.0 * static_cast<double>(kOptimizerSilence.count()) * std::pow(2.0, attempt));
  return std::chrono::milliseconds(
      static_cast<long>(1000.0 * base_s * std::uniform_real_distribution<double>(0.5, 1.5)(random)));
}

bool WorkerLink::heard() const {
  return endpoints_->reports.matched().count() > 0 && endpoints_->announcements.matched().count() > 0;
}

bool WorkerLink::rebuild() {
  // A new participant first (its readers may deliver at once), then the swap under both locks, then the
  // old one goes outside them: its listeners may be inside a callback that waits for one of those locks.
  std::unique_ptr<Endpoints> fresh;
  try {
    fresh = std::make_unique<Endpoints>(*this, config_);
  } catch (const std::exception& e) {
    spdlog::warn("worker {}: rebuilding the DDS participant failed: {}; keeping the old one", config_.worker_id,
                 e.what());
    return false;
  }
  std::unique_ptr<Endpoints> old;
  {
    std::scoped_lock lock(mutex_, announce_mutex_);
    old = std::exchange(endpoints_, std::move(fresh));
  }
  old.reset();
  return true;
}

void WorkerLink::heartbeat_until(const std::function<bool()>& stop) {
  using Clock = std::chrono::steady_clock;
  // The announcements are what keeps this worker alive for DDS (MANUAL_BY_TOPIC liveliness, topics.cpp):
  // at least two in every lease, whatever --heartbeat says.
  const auto period = std::chrono::duration_cast<Clock::duration>(
      std::chrono::duration<double>(std::min(config_.heartbeat_s, dds::kWorkerLivelinessLease_s / 2)));
  auto next = Clock::now();
  bool announced_accepting = true;
  // The optimizer reads the announcements: no reader matched for a while means none on this domain (not
  // started, another domain, a DDS-Security mismatch) or a discovery that went wrong (a discovery server
  // that lost this participant or never answered it, ports taken on a crowded host). Said in the log, once
  // per silence; with rejoin_when_unheard the worker then rebuilds its participant, after a jittered wait.
  auto last_heard = Clock::now();
  bool said_unheard = false;
  bool heard_since_built = false;
  int rejoins = 0;
  auto rejoin_wait = rejoin_after(0);  // drawn once per attempt: the silence a rebuild waits for
  auto rejoin_at = Clock::now() + rejoin_wait;
  while (!stop()) {
    // Heard: an optimizer's reports reader matched this worker (no other cpgmatch process reads reports)
    // and its announcements reach a reader. Announcement readers alone may be `cpgmatch workers` or a
    // dashboard: a worker the optimizer never matched (seen once in 200 started at once) but a polling
    // client did would otherwise count itself heard and wait for ever.
    if (heard()) {
      if (said_unheard) {
        spdlog::info("worker {}: an optimizer is on domain {} now{}", config_.worker_id, config_.domain,
                     rejoins > 0 ? fmt::format(" (after {} rebuilds of this worker's participant)", rejoins) : "");
      }
      last_heard = Clock::now();
      rejoin_at = last_heard + rejoin_wait;
      said_unheard = false;
      heard_since_built = true;
    } else {
      const auto silent = Clock::now() - last_heard;
      if (!said_unheard && silent > kOptimizerSilence) {
        spdlog::warn("worker {}: no optimizer on DDS domain {} for {} s (none running, another domain, its security "
                     "settings do not match this worker's, or discovery went wrong){}",
                     config_.worker_id, config_.domain,
                     std::chrono::duration_cast<std::chrono::seconds>(silent).count(),
                     config_.rejoin_when_unheard ? "; will rebuild this worker's DDS participant" : "");
        said_unheard = true;
      }
      if (config_.rejoin_when_unheard && Clock::now() >= rejoin_at) {
        std::size_t unacknowledged = 0;
        {
          std::lock_guard<std::mutex> lock(mutex_);
          unacknowledged = kept_.size();
        }
        // Reports not yet acknowledged live in the old writer's history, which a successor optimizer reads
        // when it comes: a worker that was heard once and holds any keeps its participant.
        if (heard_since_built && unacknowledged > 0) {
          spdlog::info("worker {}: keeps its DDS participant: {} reports wait there for the next optimizer",
                       config_.worker_id, unacknowledged);
          rejoin_at = Clock::now() + rejoin_wait;
        } else {
          const auto wait = rejoin_after(rejoins + 1);
          spdlog::warn("worker {}: no optimizer heard for {} s: rebuilding its DDS participant (attempt {}; next "
                       "attempt in {:.0f} s if still unheard)",
                       config_.worker_id, std::chrono::duration_cast<std::chrono::seconds>(silent).count(),
                       rejoins + 1, std::chrono::duration<double>(wait).count());
          if (rebuild()) {
            ++rejoins;
            heard_since_built = false;
            next = Clock::now();  // announce at once on the new participant
          }
          rejoin_wait = wait;
          rejoin_at = Clock::now() + wait;
        }
      }
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
  endpoints_->announcements.unregister(last_announcement_);
  // The unregister is the worker's goodbye (the optimizer logs a clean leave for it, and re-issues at once);
  // a participant deleted before the optimizer acknowledged it sometimes lost it, and the worker was then
  // declared silent 2.5 s later (integration.two_workers, 1 run in about 20 under a full ctest -j2).
  endpoints_->announcements.wait_for_acknowledgments(std::chrono::milliseconds(1000));
}

}  // namespace cpgmatch::worker
