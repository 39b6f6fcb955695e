#include "study_client.hpp"

#include <unistd.h>

#include <chrono>
#include <algorithm>
#include <condition_variable>
#include <mutex>
#include <random>
#include <stdexcept>
#include <thread>

#include <fmt/format.h>

#include "cpgmatch/dds/convert.hpp"
#include "cpgmatch/domain/report_json.hpp"
#include "cpgmatch/dds/participant.hpp"

namespace cpgmatch::client {

namespace {

// The JSON view of a sample, through its domain type; a sample the domain cannot hold is left out (a client
// shows what the optimizer published, and this one never publishes such a thing).
template <typename Wire>
std::optional<nlohmann::json> json_of(const Wire& sample) {
  try {
    return domain::to_json(dds::from_wire(sample));
  } catch (const dds::WireError&) {
    return std::nullopt;
  }
}

}  // namespace

struct StudyClient::Impl {
  Impl(int domain, bool localhost_only, bool read_trials, bool read_workers)
      : participant(dds::ParticipantConfig::basic(domain, "cpgmatch-cli", localhost_only)),
        client_id(fmt::format("cli-{}-{}", getpid(), std::random_device{}())) {
    state_reader = std::make_unique<dds::Reader<msg::StudyState>>(
        participant,
        [this](const msg::StudyState& s) {
          std::lock_guard<std::mutex> lock(mutex);
          if (auto j = json_of(s)) study_states[static_cast<int>(s.study_id())] = std::move(*j);
          ++revision;
        },
        // A study whose optimizer is gone (stopped, killed, restarting) is no longer shown: a long-lived client
        // (the dashboard) kept its last state for ever, "running", where a new client (`status`) did not list it
        // at all. Both now show what the optimizers on the domain publish, and a restarted optimizer publishes
        // every stored study again (issue 34).
        [this](const msg::StudyState& key, dds::InstanceGone) {
          std::lock_guard<std::mutex> lock(mutex);
          study_states.erase(static_cast<int>(key.study_id()));
          ++revision;
        });
    if (read_workers) worker_reader = std::make_unique<dds::Reader<msg::WorkerAnnouncement>>(
        participant,
        [this](const msg::WorkerAnnouncement& w) {
          std::lock_guard<std::mutex> lock(mutex);
          if (auto j = json_of(w)) live_workers[w.worker_id().to_string()] = std::move(*j);
          ++revision;
        },
        [this](const msg::WorkerAnnouncement& key, dds::InstanceGone) {
          std::lock_guard<std::mutex> lock(mutex);
          live_workers.erase(key.worker_id().to_string());
          ++revision;
        });
    if (read_trials) {
      trial_reader = std::make_unique<dds::Reader<msg::TrialRecord>>(participant, [this](const msg::TrialRecord& t) {
        std::lock_guard<std::mutex> lock(mutex);
        if (auto j = json_of(t)) trial_records[static_cast<int>(t.study_id())][static_cast<int>(t.trial_id())] = std::move(*j);
        ++revision;
      });
    }
  }

  // The command writer and the reply reader exist only in clients that send commands: with DDS-Security
  // a viewer's permissions allow neither, and merely creating them would fail.
  void open_command_channel() {
    if (commands) return;
    replies = std::make_unique<dds::Reader<msg::CommandReply>>(participant, [this](const msg::CommandReply& r) {
      std::lock_guard<std::mutex> lock(mutex);
      if (r.client_id().to_string() == client_id) received[r.correlation_id()] = r;
      changed.notify_all();
    });
    commands = std::make_unique<dds::Writer<msg::StudyCommand>>(participant);
  }

  CommandResult send(domain::StudyCommand domain_command, double timeout_s) {
    open_command_channel();
    const auto timeout = std::chrono::milliseconds(static_cast<long>(timeout_s * 1000));
    // A command written before the optimizer's reader and our reply reader are matched would be lost
    // (volatile topic), so wait for both directions first.
    if (!commands->matched().wait_for(1, timeout) || !replies->matched().wait_for(1, timeout)) {
      throw std::runtime_error(fmt::format("no optimizer answered on DDS domain {} within {:.0f} s",
                                           participant.domain(), timeout_s));
    }
    std::mt19937_64 rng(std::random_device{}());
    domain_command.correlation_id = rng();
    domain_command.client_id = client_id;
    const msg::StudyCommand command = dds::to_wire(domain_command);
    // At least once: re-send until a reply arrives. The optimizer answers a repeated correlation_id
    // from its reply cache, so a re-sent submit never creates a second study.
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    std::unique_lock<std::mutex> lock(mutex);
    while (received.count(command.correlation_id()) == 0) {
      if (std::chrono::steady_clock::now() >= deadline) {
        throw std::runtime_error(fmt::format("the optimizer did not reply within {:.0f} s", timeout_s));
      }
      lock.unlock();
      if (!commands->write(command)) throw std::runtime_error("DDS write of the command failed");
      lock.lock();
      changed.wait_until(lock, std::min(deadline, std::chrono::steady_clock::now() + std::chrono::seconds(2)),
                         [&] { return received.count(command.correlation_id()) > 0; });
    }
    const domain::CommandReply r = dds::from_wire(received.at(command.correlation_id()));
    return {r.ok, r.study_id, r.message};
  }

  dds::Participant participant;
  std::unique_ptr<dds::Writer<msg::StudyCommand>> commands;  // see open_command_channel()
  std::string client_id;
  mutable std::mutex mutex;
  std::condition_variable changed;
  std::map<std::uint64_t, msg::CommandReply> received;
  std::map<int, nlohmann::json> study_states;
  std::map<std::string, nlohmann::json> live_workers;
  std::map<int, std::map<int, nlohmann::json>> trial_records;
  std::uint64_t revision = 0;  // +1 for every state, worker or trial sample taken in
  // Readers last: their callbacks use the members above.
  std::unique_ptr<dds::Reader<msg::CommandReply>> replies;
  std::unique_ptr<dds::Reader<msg::StudyState>> state_reader;
  std::unique_ptr<dds::Reader<msg::WorkerAnnouncement>> worker_reader;
  std::unique_ptr<dds::Reader<msg::TrialRecord>> trial_reader;
};

StudyClient::StudyClient(int domain, bool localhost_only, bool read_trials, bool read_workers)
    : impl_(std::make_unique<Impl>(domain, localhost_only, read_trials, read_workers)) {}

StudyClient::~StudyClient() {
  // Readers go before the state they write into.
  impl_->trial_reader.reset();
  impl_->worker_reader.reset();
  impl_->state_reader.reset();
  impl_->replies.reset();
}

CommandResult StudyClient::submit(const std::string& study_yaml, const std::string& source_name, double timeout_s,
                                  const std::vector<domain::EnqueuedGait>& enqueue) {
  domain::StudyCommand c;
  c.kind = domain::CommandKind::kSubmit;
  c.study_yaml = study_yaml;
  c.source_name = source_name;
  c.enqueue = enqueue;
  return impl_->send(c, timeout_s);
}

CommandResult StudyClient::extend(int study_id, int added_trials, double timeout_s) {
  domain::StudyCommand c;
  c.kind = domain::CommandKind::kExtend;
  c.study_id = study_id;
  c.added_trials = added_trials;
  return impl_->send(c, timeout_s);
}

CommandResult StudyClient::enqueue(int study_id, const std::vector<domain::EnqueuedGait>& gaits, double timeout_s) {
  domain::StudyCommand c;
  c.kind = domain::CommandKind::kEnqueue;
  c.study_id = study_id;
  c.enqueue = gaits;
  return impl_->send(c, timeout_s);
}

CommandResult StudyClient::control(const std::string& kind, int study_id, double timeout_s) {
  domain::StudyCommand c;
  if (kind == "pause") c.kind = domain::CommandKind::kPause;
  else if (kind == "resume") c.kind = domain::CommandKind::kResume;
  else if (kind == "stop") c.kind = domain::CommandKind::kStop;
  else throw std::invalid_argument("unknown command " + kind);
  c.study_id = study_id;
  return impl_->send(c, timeout_s);
}

bool StudyClient::wait_for_optimizer(double timeout_s, double settle_s) {
  if (!impl_->state_reader->matched().wait_for(1, std::chrono::milliseconds(static_cast<long>(timeout_s * 1000)))) {
    return false;
  }
  std::this_thread::sleep_for(std::chrono::duration<double>(settle_s));
  return true;
}

bool StudyClient::wait_for_workers(double timeout_s) {
  using Clock = std::chrono::steady_clock;
  if (!impl_->worker_reader) throw std::logic_error("StudyClient: made without read_workers");
  const auto& matched = impl_->worker_reader->matched();
  const auto deadline = Clock::now() + std::chrono::milliseconds(static_cast<long>(timeout_s * 1000));
  if (!matched.wait_for(1, std::chrono::milliseconds(static_cast<long>(timeout_s * 1000)))) return false;
  // A fleet is introduced a few workers at a time (a discovery server relays the endpoints in bursts): wait
  // while the matches still grow, until none came for a second or the timeout.
  int seen = matched.count();
  auto last_growth = Clock::now();
  while (Clock::now() < deadline && Clock::now() - last_growth < std::chrono::seconds(1)) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    if (matched.count() > seen) {
      seen = matched.count();
      last_growth = Clock::now();
    }
  }
  // Workers announce every 0.5 s (WorkerLinkConfig::heartbeat_s): two periods hear every matched one.
  const auto heard_deadline = Clock::now() + std::chrono::milliseconds(1500);
  while (Clock::now() < heard_deadline) {
    {
      std::lock_guard<std::mutex> lock(impl_->mutex);
      if (static_cast<int>(impl_->live_workers.size()) >= matched.count()) return true;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return true;
}

int StudyClient::matched_workers() const {
  return impl_->worker_reader ? impl_->worker_reader->matched().count() : 0;
}

std::optional<int> StudyClient::optimizer_worker_count() const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  std::optional<int> n;
  for (const auto& [id, s] : impl_->study_states) {
    if (s.contains("workers")) n = std::max(n.value_or(0), s["workers"].get<int>());
  }
  return n;
}

bool StudyClient::wait_for_study(int study_id, double timeout_s) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (std::chrono::steady_clock::now() < deadline) {
    {
      std::lock_guard<std::mutex> lock(impl_->mutex);
      if (impl_->study_states.count(study_id)) return true;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return false;
}

std::uint64_t StudyClient::revision() const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  return impl_->revision;
}

std::map<int, nlohmann::json> StudyClient::states() const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  return impl_->study_states;
}

std::map<std::string, nlohmann::json> StudyClient::workers() const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  return impl_->live_workers;
}

std::vector<nlohmann::json> StudyClient::trials(int study_id) const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  std::vector<nlohmann::json> out;
  if (auto it = impl_->trial_records.find(study_id); it != impl_->trial_records.end()) {
    for (const auto& [id, t] : it->second) out.push_back(t);
  }
  return out;
}

}  // namespace cpgmatch::client
