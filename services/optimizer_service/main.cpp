// cpgmatch-optimizer: the central optimizer service. Hosts any number of studies, each with its own
// Bayesian optimizer; hands candidates to the workers it hears on the domain and keeps their slots
// busy; stores everything in an SQLite file and resumes from it after a restart.
//
//   cpgmatch-optimizer --domain 7 --store studies.db
//
// DDS listeners only queue samples; one thread runs the coordinator (see coordinator.hpp).
#include <csignal>
#include <cstdlib>
#include <iostream>
#include <variant>

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include "cpgmatch/dds/domain.hpp"
#include "cpgmatch/dds/participant.hpp"
#include "cpgmatch/errors.hpp"
#include "cpgmatch/runtime/install_layout.hpp"
#include "cpgmatch/runtime/shared_flags.hpp"
#include "cpgmatch/service/coordinator.hpp"
#include "cpgmatch/sim/sim_rollout.hpp"
#include "cpgmatch/study/store_lock.hpp"
#include "event_queue.hpp"

namespace cpgmatch::service {
namespace {

volatile std::sig_atomic_t g_stop = 0;
void on_signal(int) { g_stop = 1; }

// Monotonic: the coordinator's timeouts and leases run on it (the store gets Unix time separately).
double monotonic_now_s() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

struct WorkerGone {
  std::uint64_t key;
};
using Event = std::variant<msg::StudyCommand, msg::RolloutReport, msg::WorkerAnnouncement, WorkerGone>;

// Publishes what the coordinator decides.
class DdsOutbox final : public Outbox {
 public:
  explicit DdsOutbox(dds::Participant& p) : candidates_(p), trials_(p), states_(p), replies_(p) {}
  void send_candidate(const msg::Candidate& c) override { check(candidates_.write(c), "candidate"); }
  void retire_candidate(const msg::Candidate& c) override { candidates_.unregister(c); }
  void publish_trial(const msg::TrialRecord& t) override { check(trials_.write(t), "trial record"); }
  void publish_state(const msg::StudyState& s) override { check(states_.write(s), "study state"); }
  void reply(const msg::CommandReply& r) override { check(replies_.write(r), "command reply"); }

 private:
  static void check(bool ok, const char* what) {
    if (!ok) spdlog::warn("DDS write of a {} failed", what);
  }
  dds::Writer<msg::Candidate> candidates_;
  dds::Writer<msg::TrialRecord> trials_;
  dds::Writer<msg::StudyState> states_;
  dds::Writer<msg::CommandReply> replies_;
};

int run(int domain, const std::string& store_path, bool full_durability, double worker_timeout_s, bool localhost_only) {
  dds::validate_domain(domain);
  if (worker_timeout_s <= 0.0) throw InputError("--worker-timeout must be > 0");
  const study::StoreLock lock(store_path);  // before the store is touched: one optimizer per store
  study::StudyStore store(store_path, full_durability ? study::Durability::kFull : study::Durability::kNormal);
  service::CoordinatorOptions options;
  options.worker_timeout_s = worker_timeout_s;
  options.base_parameters = load_parameters(sim::default_params_path());

  dds::ParticipantConfig dds_config{domain, "cpgmatch-optimizer", localhost_only};
  // Two optimizers on one domain would both answer commands and publish colliding study ids: say so loudly.
  dds_config.on_peer_discovered = [domain](const std::string& name) {
    if (name == "cpgmatch-optimizer") {
      spdlog::error("another cpgmatch-optimizer joined DDS domain {}: two optimizers on one domain answer the same "
                    "commands and publish colliding study ids; stop one of them or use another --domain",
                    domain);
    }
  };
  dds::Participant participant(dds_config);
  DdsOutbox outbox(participant);
  service::Coordinator coordinator(
      store, outbox, options, [](const std::string& m) { spdlog::info("{}", m); },
      [](const std::string& m) { spdlog::warn("{}", m); });
  coordinator.resume_from_store(monotonic_now_s());

  service::EventQueue<Event> queue;
  dds::Reader<msg::StudyCommand> commands(participant, [&](const msg::StudyCommand& c) { queue.push(c); });
  dds::Reader<msg::RolloutReport> reports(participant, [&](const msg::RolloutReport& r) { queue.push(r); });
  dds::Reader<msg::WorkerAnnouncement> workers(
      participant, [&](const msg::WorkerAnnouncement& w) { queue.push(w); },
      [&](const msg::WorkerAnnouncement& key, dds::InstanceGone) { queue.push(WorkerGone{key.worker_key()}); });
  spdlog::info("optimizer on domain {} with store {} ({} studies)", domain, store_path, coordinator.studies());

  while (!g_stop) {
    for (auto& event : queue.drain(std::chrono::milliseconds(20))) {
      const double now = monotonic_now_s();
      try {
        std::visit(
            [&](auto& e) {
              using T = std::decay_t<decltype(e)>;
              if constexpr (std::is_same_v<T, msg::StudyCommand>) coordinator.handle_command(e, now);
              else if constexpr (std::is_same_v<T, msg::RolloutReport>) coordinator.handle_report(e, now);
              else if constexpr (std::is_same_v<T, msg::WorkerAnnouncement>) coordinator.handle_worker(e, now);
              else coordinator.handle_worker_gone(e.key, now);
            },
            event);
      } catch (const std::exception& e) {
        // A sample that slipped past validation must not take the service down.
        spdlog::error("event dropped: {}", e.what());
      }
    }
    coordinator.tick(monotonic_now_s());
  }
  spdlog::info("optimizer stopping; every study is in {}", store_path);
  return kExitOk;
}

}  // namespace
}  // namespace cpgmatch::service

int main(int argc, char** argv) {
  using namespace cpgmatch;
  using cpgmatch::service::on_signal;
  CLI::App app{"cpgmatch-optimizer: the central optimizer service (studies, candidates, reports over DDS)"};
  int domain = -1;
  std::string store = "cpgmatch-studies.db";
  bool full_durability = false, localhost_only = false;
  double worker_timeout_s = 2.5;
  std::string log_level = "info";
  app.add_option("--domain", domain, "DDS domain id (default: $CPGMATCH_DOMAIN, else 0)");
  app.add_option("--store", store, "SQLite study store; created if missing, resumed if present")->capture_default_str();
  app.add_flag("--fsync", full_durability, "fsync every commit (survives power loss, not only a crash)");
  app.add_option("--worker-timeout", worker_timeout_s, "seconds without a heartbeat before a worker is dropped")
      ->capture_default_str();
  app.add_flag("--localhost-only", localhost_only, "UDP on 127.0.0.1 only (a private study on one machine)");
  app.add_option("--log-level", log_level, "log level")
      ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error"}))
      ->capture_default_str();
  runtime::DdsFlags dds_flags;
  runtime::add_dds_flags(app, dds_flags, "optimizer");
  runtime::add_version_flag(app, "cpgmatch-optimizer");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? kExitOk : kExitBadInput;
  }
  spdlog::set_default_logger(spdlog::stderr_color_mt("optimizer"));
  spdlog::set_level(spdlog::level::from_str(log_level));
  std::signal(SIGTERM, on_signal);
  std::signal(SIGINT, on_signal);
  return run_reporting_errors([&] {
    runtime::export_config_dir();
    runtime::apply_dds_flags(dds_flags);
    return service::run(domain >= 0 ? domain : cpgmatch::dds::default_domain(), store, full_durability,
                        worker_timeout_s, localhost_only);
  });
}
