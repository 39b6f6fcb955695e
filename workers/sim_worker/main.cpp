// cpgmatch-sim-worker: runs simulated rollouts for the optimizer service.
//
//   cpgmatch-sim-worker --domain 7 --slots 8 --id node12
//
// Announces itself (id, capacity, load) every heartbeat; reads only the candidates assigned to it (a
// content filter on worker_id); runs up to --slots rollouts at once, each in its own process because
// Debian's ODE is not thread-safe; returns one report per candidate. On SIGTERM it stops accepting,
// finishes the rollouts already running, hands back the queued ones (by leaving the domain, which makes
// the optimizer re-issue them) and exits 0.
#include <unistd.h>

#include <condition_variable>
#include <csignal>
#include <deque>
#include <iostream>
#include <iterator>
#include <map>
#include <mutex>
#include <optional>
#include <tuple>
#include <thread>

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include "cpgmatch/dds/convert.hpp"
#include "cpgmatch/dds/domain.hpp"
#include "cpgmatch/dds/participant.hpp"
#include "cpgmatch/errors.hpp"
#include "cpgmatch/runtime/install_layout.hpp"
#include "cpgmatch/runtime/shared_flags.hpp"
#include "cpgmatch/worker/candidate_queue.hpp"
#include "rollout_slot.hpp"

namespace cpgmatch::worker {
namespace {

volatile std::sig_atomic_t g_stop = 0;
void on_signal(int) { g_stop = 1; }

// Reports stay in the writer's transient-local history so that an optimizer restarting mid-study still
// receives them, until the optimizer disposes the candidate (it does once the report is in its store):
// then the report is unregistered, which frees it here and its instance in the optimizer's reader. The
// oldest are unregistered anyway once this many are kept (an optimizer that never acknowledges).
constexpr std::size_t kReportsKept = 4096;

struct Options {
  int domain = -1;
  int slots = -1;  // -1: number of cores
  std::string id;
  double fake_rollout_ms = -1.0;
  double heartbeat_s = 0.5;
  bool localhost_only = false;
};

class SimWorker {
 public:
  explicit SimWorker(const Options& o)
      : options_(o),
        participant_(dds::ParticipantConfig{o.domain, "cpgmatch-sim-worker " + o.id, o.localhost_only}),
        reports_(participant_),
        announcements_(participant_),
        queue_(o.id),
        candidates_(participant_, "candidates_for_" + o.id, "worker_id = %0", {"'" + o.id + "'"},
                    [this](const msg::Candidate& c) { queue_.offer(c); }),
        // The content filter cannot read a dispose (a key-only sample), so disposes come through an
        // unfiltered reader: the candidates of other workers are only remembered until their dispose.
        acknowledgements_(participant_, {}, [this](const msg::Candidate& key, dds::InstanceGone gone) {
          if (gone.disposed) report_acknowledged(key);  // not on a lost optimizer: its successor needs them
        }) {
    slot_options_.worker_id = o.id;
    slot_options_.fake_rollout_s = o.fake_rollout_ms >= 0.0 ? o.fake_rollout_ms / 1000.0 : -1.0;
    for (int i = 0; i < o.slots; ++i) slots_.emplace_back([this] { slot_loop(); });
  }

  void run() {
    char host[256] = "unknown";
    gethostname(host, sizeof(host) - 1);
    host_ = host;
    spdlog::info("worker {} on domain {}: {} slots{}", options_.id, options_.domain, options_.slots,
                 slot_options_.fake_rollout_s >= 0.0 ? fmt::format(", fake rollouts of {} ms", options_.fake_rollout_ms) : "");
    while (!g_stop) {
      announce(true);
      std::unique_lock<std::mutex> lock(mutex_);
      wake_.wait_for(lock, std::chrono::duration<double>(options_.heartbeat_s), [] { return g_stop != 0; });
    }
    shutdown();
  }

 private:
  void report_acknowledged(const msg::Candidate& key) {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto it = kept_.find({key.store_id(), key.study_id(), key.trial_id()});
    if (it == kept_.end()) return;
    reports_.unregister(it->second);
    kept_.erase(it);
  }

  void slot_loop() {
    while (const std::optional<msg::Candidate> c = queue_.take()) {
      const msg::RolloutReport report = execute_candidate(*c, slot_options_);
      if (!report.ok()) spdlog::warn("study {} trial {}: {}", c->study_id(), c->trial_id(), report.error().to_string());
      write_report(report);
      queue_.finish(*c);
    }
  }

  void write_report(const msg::RolloutReport& report) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!reports_.write(report)) spdlog::error("study {} trial {}: report write failed", report.study_id(), report.trial_id());
    const ReportKey key{report.store_id(), report.study_id(), report.trial_id()};
    kept_[key] = report;
    kept_order_.push_back(key);
    if (kept_order_.size() > 2 * kReportsKept) {  // drop the acknowledged ones from the order
      std::deque<ReportKey> live;
      for (const auto& k : kept_order_) if (kept_.count(k)) live.push_back(k);
      kept_order_.swap(live);
    }
    while (kept_.size() > kReportsKept) {
      if (const auto oldest = kept_.find(kept_order_.front()); oldest != kept_.end()) {
        reports_.unregister(oldest->second);
        kept_.erase(oldest);
      }
      kept_order_.pop_front();
    }
  }

  void announce(bool accepting) {
    msg::WorkerAnnouncement a;
    a.worker_key(dds::worker_key(options_.id));
    a.worker_id(options_.id);
    a.kind(msg::WORKER_SIM);
    a.host(host_);
    a.pid(static_cast<std::uint32_t>(getpid()));
    a.slots(static_cast<std::uint32_t>(options_.slots));
    a.heartbeat_period_s(options_.heartbeat_s);
    a.accepting(accepting);
    const CandidateQueue::Load load = queue_.load();
    a.busy(load.busy);
    a.completed(load.completed);
    announcements_.write(a);
    last_announcement_ = a;
  }

  void shutdown() {
    spdlog::info("worker {}: stopping; finishing {} running rollouts", options_.id, queue_.load().busy);
    announce(false);
    const std::size_t handed_back = queue_.drain();
    if (handed_back) spdlog::info("worker {}: handing back {} queued candidates", options_.id, handed_back);
    for (auto& t : slots_) t.join();
    // Give reliable delivery of the last reports a moment before the writer goes away.
    reports_.matched().wait_for(1, std::chrono::milliseconds(0));
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    announcements_.unregister(last_announcement_);
    spdlog::info("worker {}: {} rollouts done, bye", options_.id, queue_.load().completed);
  }

  Options options_;
  SlotOptions slot_options_;
  std::string host_;
  dds::Participant participant_;
  dds::Writer<msg::RolloutReport> reports_;
  dds::Writer<msg::WorkerAnnouncement> announcements_;
  CandidateQueue queue_;
  std::mutex mutex_;               // the report writer and the kept reports
  std::condition_variable wake_;   // the heartbeat's sleep
  using ReportKey = std::tuple<std::uint64_t, std::uint32_t, std::uint32_t>;  // store, study, trial: the topic's key
  std::map<ReportKey, msg::RolloutReport> kept_;              // written, not yet acknowledged
  std::deque<ReportKey> kept_order_;                           // in writing order (may name acknowledged ones)
  msg::WorkerAnnouncement last_announcement_;
  std::vector<std::thread> slots_;
  // Last: the readers' callbacks use everything above, so they must be created after and destroyed first.
  dds::Reader<msg::Candidate> candidates_;
  dds::Reader<msg::Candidate> acknowledgements_;
};

// `--run-one`: one rollout whose request arrives as JSON on stdin; prints the report JSON and the cost.
int run_one() {
  const std::string input((std::istreambuf_iterator<char>(std::cin)), std::istreambuf_iterator<char>());
  nlohmann::json request;
  try {
    request = nlohmann::json::parse(input);
  } catch (const nlohmann::json::exception& e) {
    throw InputError(fmt::format("stdin: not a JSON rollout request: {}", e.what()));
  }
  const nlohmann::json report = run_rollout_request(request);
  std::cout << report.dump() << '\n' << fmt::format("{:.17g}", report.at("cost").get<double>()) << std::endl;
  return kExitOk;
}

}  // namespace
}  // namespace cpgmatch::worker

int main(int argc, char** argv) {
  using namespace cpgmatch;
  CLI::App app{"cpgmatch-sim-worker: runs simulated rollouts for the optimizer service"};
  worker::Options o;
  bool run_one = false;
  std::string log_level = "info";
  app.add_option("--domain", o.domain, "DDS domain id (default: $CPGMATCH_DOMAIN, else 0)");
  app.add_option("--slots", o.slots, "concurrent rollouts (default: number of cores)");
  app.add_option("--id", o.id, "worker id, unique on the domain (default: HOST-PID)");
  app.add_option("--fake-rollout-ms", o.fake_rollout_ms,
                 "benchmark mode: replace each rollout by a fixed delay (ms) and a synthetic cost");
  app.add_option("--heartbeat", o.heartbeat_s, "seconds between announcements")->capture_default_str();
  app.add_flag("--localhost-only", o.localhost_only, "UDP on 127.0.0.1 only (a private study on one machine)");
  app.add_option("--log-level", log_level, "log level")
      ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error"}))
      ->capture_default_str();
  runtime::DdsFlags dds_flags;
  runtime::add_dds_flags(app, dds_flags, "worker");
  runtime::add_version_flag(app, "cpgmatch-sim-worker");
  app.add_flag("--run-one", run_one, "internal: one rollout, request as JSON on stdin")->group("");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? kExitOk : kExitBadInput;
  }
  spdlog::set_default_logger(spdlog::stderr_color_mt("worker"));
  spdlog::set_level(spdlog::level::from_str(log_level));
  return run_reporting_errors([&] {
    runtime::export_config_dir();
    if (run_one) return worker::run_one();
    runtime::apply_dds_flags(dds_flags);
    if (o.domain < 0) o.domain = cpgmatch::dds::default_domain();
    cpgmatch::dds::validate_domain(o.domain);
    if (o.slots == -1) o.slots = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
    if (o.slots < 1 || o.slots > 4096) throw InputError(fmt::format("--slots must be in 1..4096, got {}", o.slots));
    if (o.heartbeat_s <= 0.0 || o.heartbeat_s > 10.0) throw InputError("--heartbeat must be in (0, 10] s");
    if (o.id.empty()) {
      char host[256] = "host";
      gethostname(host, sizeof(host) - 1);
      o.id = fmt::format("{}-{}", host, getpid());
    }
    if (o.id.size() > 63) throw InputError(fmt::format("--id: at most 63 characters, got {}", o.id.size()));
    if (o.id.find('\'') != std::string::npos) throw InputError("--id must not contain a quote");
    std::signal(SIGTERM, worker::on_signal);
    std::signal(SIGINT, worker::on_signal);
    worker::SimWorker w(o);
    w.run();
    return kExitOk;
  });
}
