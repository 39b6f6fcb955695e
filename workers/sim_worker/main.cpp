// cpgmatch-sim-worker: runs simulated rollouts for the optimizer service.
//
//   cpgmatch-sim-worker --domain 7 --slots 8 --id node12
//
// Announces itself (id, capacity, load) every heartbeat; receives the candidates addressed to it (the
// optimizer's writer filters on worker_id, see worker_link.hpp); runs up to --slots rollouts at once, each in its
// own process because Debian's ODE is not thread-safe (a process kept per slot, `--serve-rollouts`, that is
// sent each study's spec once); returns one report per candidate. On SIGTERM it
// stops accepting, finishes the rollouts already running, hands back the queued ones (by leaving the
// domain, which makes the optimizer re-issue them) and exits 0.
#include <sys/prctl.h>
#include <unistd.h>

#include <csignal>
#include <cstdio>
#include <iostream>
#include <iterator>
#include <optional>
#include <thread>
#include <vector>

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include "cpgmatch/dds/domain.hpp"
#include "cpgmatch/errors.hpp"
#include "cpgmatch/runtime/install_layout.hpp"
#include "cpgmatch/runtime/man_pages.hpp"
#include "cpgmatch/runtime/shared_flags.hpp"
#include "cpgmatch/domain/report_json.hpp"
#include "cpgmatch/sim/ode_errors.hpp"
#include "cpgmatch/worker/candidate_queue.hpp"
#include "cpgmatch/worker/spec_book.hpp"
#include "cpgmatch/worker/worker_link.hpp"
#include "rollout_request.hpp"
#include "rollout_server.hpp"
#include "rollout_slot.hpp"

namespace cpgmatch::worker {
namespace {

volatile std::sig_atomic_t g_stop = 0;
void on_signal(int) { g_stop = 1; }

struct Options {
  int domain = -1;
  int slots = -1;  // -1: number of cores
  std::string id;
  double fake_rollout_ms = -1.0;
  double heartbeat_s = 0.5;
  bool localhost_only = false;
  int objective_version = study::kObjectiveVersion;
};

std::string host_name() {
  char host[256] = "unknown";
  gethostname(host, sizeof(host) - 1);
  return host;
}

WorkerLinkConfig link_config(const Options& o) {
  WorkerLinkConfig c{o.domain, o.id, "cpgmatch-sim-worker " + o.id, o.localhost_only, domain::WorkerKind::kSimulation,
                     static_cast<std::uint32_t>(o.slots), o.heartbeat_s, host_name(), {}, o.objective_version};
  // A worker that hears no optimizer joins again by itself (a fleet started at once, a lost discovery).
  c.rejoin_when_unheard = true;
  return c;
}

// The DDS side (candidates, reports kept until acknowledged, heartbeats) is the WorkerLink every worker
// shares; what is this worker's own is running each candidate in a slot process.
class SimWorker {
 public:
  explicit SimWorker(const Options& o)
      : options_(o),
        queue_(o.id),
        link_(link_config(o), queue_),
        specs_(link_, o.objective_version) {
    slot_options_.worker_id = o.id;
    slot_options_.find_spec = [this](std::uint64_t key) {
      SpecBook::Lookup found = specs_.find(key);
      return SpecLookup{std::move(found.spec), std::move(found.refusal)};
    };
    slot_options_.fake_rollout_s = o.fake_rollout_ms >= 0.0 ? o.fake_rollout_ms / 1000.0 : -1.0;
    for (int i = 0; i < o.slots; ++i) slots_.emplace_back([this] { slot_loop(); });
  }

  void run() {
    spdlog::info("worker {} on domain {}: {} slots{}", options_.id, options_.domain, options_.slots,
                 slot_options_.fake_rollout_s >= 0.0 ? fmt::format(", fake rollouts of {} ms", options_.fake_rollout_ms) : "");
    link_.heartbeat_until([] { return g_stop != 0; });
    shutdown();
  }

 private:
  // Each slot keeps its rollout process on its own thread (it dies with the thread that started it),
  // started before the first candidate, and ends it when the slot ends.
  void slot_loop() {
    RolloutSlot slot(slot_options_);
    slot.prepare();  // while the worker is still being discovered, not when its first candidate arrives
    while (const std::optional<domain::Candidate> c = queue_.take()) {
      const domain::RolloutReport report = slot.execute(*c);
      if (!report.ok()) spdlog::warn("study {} trial {}: {}", c->id.study_id, c->id.trial_id, report.error);
      link_.publish(report);
      queue_.finish(*c);
      slot.prepare();  // after the report is out: a process the candidate cost is replaced before the next
    }
  }

  // On SIGTERM: finish the running rollouts, hand back the queued ones (the optimizer re-issues them once
  // this worker has left the domain).
  void shutdown() {
    spdlog::info("worker {}: stopping; finishing {} running rollouts", options_.id, queue_.load().busy);
    const std::size_t handed_back = queue_.drain();
    if (handed_back) spdlog::info("worker {}: handing back {} queued candidates", options_.id, handed_back);
    for (auto& t : slots_) t.join();
    link_.leave();
    spdlog::info("worker {}: {} rollouts done, bye", options_.id, queue_.load().completed);
  }

  Options options_;
  SlotOptions slot_options_;
  CandidateQueue queue_;
  WorkerLink link_;  // after the queue: its readers feed the queue from the moment it exists
  SpecBook specs_;
  std::vector<std::thread> slots_;
};

// `--run-one`: one rollout whose request arrives as JSON on stdin; prints the report JSON and the cost.
// An ODE failure in a rollout process: the rollout diverged (the model or the gait took ODE where it cannot
// step), reported as such with ODE's reason, instead of the process dying with SIGABRT.
[[noreturn]] void report_ode_failure(const std::string& reason) {
  domain::RolloutReport r;
  r.outcome = domain::Outcome::kDiverged;
  r.error = "simulation failed: " + reason;
  // The cost of a diverged rollout is a placeholder the optimizer does not learn from (its outcome says so);
  // the last line must still be a finite number.
  std::fputs((domain::to_json(r).dump() + "\n0\n").c_str(), stdout);
  std::fflush(stdout);
  _exit(kExitOk);
}

int run_one() {
  // This process is worthless once its worker is gone, even when the worker is SIGKILLed. The worker's fork
  // sets this too, but a shell between them would not pass it on; checked again after setting it, in case
  // the worker died in between.
  const pid_t parent = getppid();
  prctl(PR_SET_PDEATHSIG, SIGKILL);
  if (parent == 1 || getppid() != parent) return kExitFailure;
  sim::set_ode_failure_hook(report_ode_failure);
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
  bool serve_rollouts = false;
  std::string log_level = "info";
  app.add_option("--domain", o.domain, "DDS domain id (default: $CPGMATCH_DOMAIN, else $ROS_DOMAIN_ID, else 0)");
  app.add_option("--slots", o.slots, "concurrent rollouts (default: number of cores)");
  app.add_option("--id", o.id,
                 "worker id, unique on the domain (default: HOST-PID; with --keystore the certificate's CN, and an id "
                 "must be CN or CN/SUFFIX)");
  app.add_option("--fake-rollout-ms", o.fake_rollout_ms,
                 "benchmark mode: replace each rollout by a fixed delay (ms) and a synthetic cost");
  app.add_option("--heartbeat", o.heartbeat_s, "seconds between announcements")->capture_default_str();
  app.add_option("--objective-version", o.objective_version,
                 "compatibility tests only: claim to compute this objective version (a release's is fixed)")
      ->group("");
  app.add_flag("--localhost-only", o.localhost_only, "UDP on 127.0.0.1 only (a private study on one machine)");
  app.add_option("--log-level", log_level, "log level")
      ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error"}))
      ->capture_default_str();
  runtime::DdsFlags dds_flags;
  runtime::add_dds_flags(app, dds_flags, "worker");
  runtime::add_version_flag(app, "cpgmatch-sim-worker");
  runtime::add_man_page_flag(app, "cpgmatch-sim-worker");
  app.add_flag("--run-one", run_one, "internal: one rollout, request as JSON on stdin")->group("");
  app.add_flag("--serve-rollouts", serve_rollouts,
               "internal: a slot's rollout process, one request per line on stdin, one answer per line on stdout")
      ->group("");
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
    if (serve_rollouts) return worker::serve_rollouts();
    runtime::apply_dds_flags(dds_flags);
    if (o.domain < 0) o.domain = cpgmatch::dds::default_domain();
    cpgmatch::dds::validate_domain(o.domain);
    if (o.slots == -1) o.slots = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
    if (o.slots < 1 || o.slots > 4096) throw InputError(fmt::format("--slots must be in 1..4096, got {}", o.slots));
    if (o.heartbeat_s <= 0.0 || o.heartbeat_s > 10.0) throw InputError("--heartbeat must be in (0, 10] s");
    {
      char host[256] = "host";
      gethostname(host, sizeof(host) - 1);
      o.id = runtime::resolve_worker_id(o.id, fmt::format("{}-{}", host, getpid()));  // with --keystore: its CN
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
