#include "local_study.hpp"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <optional>
#include <thread>

#include <fmt/format.h>

#include "child_process.hpp"
#include "gait_files.hpp"
#include "private_keystore.hpp"
#include "cpgmatch/runtime/domain_lease.hpp"
#include "cpgmatch/runtime/shared_flags.hpp"
#include "cpgmatch/command_objective.hpp"
#include "cpgmatch/dds/domain.hpp"
#include "cpgmatch/dds/security.hpp"
#include "cpgmatch/errors.hpp"
#include "cpgmatch/text.hpp"
#include "cpgmatch/yaml_reader.hpp"
#include "cpgmatch/study/robot_file.hpp"
#include "service_flags.hpp"
#include "study_client.hpp"

namespace cpgmatch::cli {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

class ProgressBar {
 public:
  ProgressBar(int total, bool quiet, std::string label)
      : total_(total), quiet_(quiet), tty_(isatty(STDERR_FILENO)), label_(std::move(label)) {}
  void update(int done, double best, double elapsed) {
    if (quiet_) return;
    const double rate = elapsed > 0 ? done / elapsed : 0.0;
    const double eta = rate > 0 ? (total_ - done) / rate : 0.0;
    const int width = 30, filled = total_ > 0 ? width * done / total_ : width;
    std::string bar(filled, '#');
    bar += std::string(width - filled, '.');
    fmt::print(stderr, "{}{}[{}] {:>4}/{} best {:<9.4g} {:5.2f} rollouts/s  elapsed {:5.1f}s  eta {:5.1f}s{}",
               tty_ ? "\r" : "", label_, bar, done, total_, best, rate, elapsed, eta, tty_ ? "" : "\n");
    if (tty_ && done == total_) fmt::print(stderr, "\n");
  }

 private:
  int total_;
  bool quiet_;
  bool tty_;
  std::string label_;
};

// A domain id of this run's own, so that two local studies on one machine do not meet: leased from
// 150-229 (starting at 150 + pid % 80) for as long as the study runs.
runtime::DomainLease lease_private_domain() {
  return runtime::DomainLease::acquire(150, 80, static_cast<int>(getpid() % 80),
                                       runtime::DomainLease::default_lock_dir());
}

volatile std::sig_atomic_t g_interrupted = 0;

// SIGTERM to every child, then waits for all of them together, SIGKILL after `grace_s`; the optimizer last, so
// the workers' final reports still reach it.
void stop_children(std::vector<std::unique_ptr<ChildProcess>>& children, double grace_s) {
  for (auto it = children.rbegin(); it != children.rend(); ++it) {
    if (it + 1 != children.rend()) (*it)->signal(SIGTERM);
  }
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(grace_s);
  for (auto it = children.rbegin(); it != children.rend(); ++it) {
    const double left = std::chrono::duration<double>(deadline - std::chrono::steady_clock::now()).count();
    (*it)->stop(std::max(0.0, left));
  }
}

}  // namespace

std::optional<std::string> every_trial_failed(const std::vector<nlohmann::json>& records) {
  if (records.empty()) return std::nullopt;
  std::string first;
  for (const auto& r : records) {
    const std::string outcome = r.at("report").value("outcome", "");
    if (outcome == "completed" || outcome == "fell") return std::nullopt;
    if (first.empty()) first = fmt::format("{}: {}", outcome, r.at("report").value("error", ""));
  }
  return fmt::format("every one of its {} trials failed (none completed or fell); the first: {}", records.size(),
                     first);
}

namespace {

}  // namespace

fs::path timestamped_results_dir(const std::string& prefix) {
  const auto stamp = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  char buf[32];
  std::strftime(buf, sizeof(buf), "%Y%m%d-%H%M%S", std::localtime(&stamp));
  return fs::path("results") / fmt::format("{}-{}", prefix, buf);
}

void LocalStudyFlags::add_to(CLI::App& cmd, const std::string& out_help) {
  cmd.add_option("--config", config, "study YAML (default: the paper's study)");
  cmd.add_option("--workers", workers, "simulation workers, one rollout each at a time (default: number of cores)");
  cmd.add_option("--out", out, out_help);
  cmd.add_option("--jitter", jitter, "re-run the best parameters N times under +-1% jitter (0: skip)");
  cmd.add_flag("--quiet", quiet, "no progress on stderr");
  cmd.add_flag("--insecure", insecure,
               "no DDS-Security: any local user can then read and steer the study (default: a private keystore "
               "made for this run, or $CPGMATCH_KEYSTORE)");
}

LocalStudyOptions LocalStudyFlags::options() const {
  if (workers < 0) throw InputError(fmt::format("--workers {}: must be >= 1 (0: one per core)", workers));
  if (jitter < 0) throw InputError(fmt::format("--jitter {}: must be >= 0", jitter));
  LocalStudyOptions o = config.empty() ? paper_study_options() : study_file_options(config);
  o.workers = workers;
  o.out = out;
  o.quiet = quiet;
  o.insecure = insecure;
  return o;
}

LocalStudyOptions paper_study_options() {
  LocalStudyOptions o;
  o.config_text = "# the paper's study: every key but the name has the paper's value\nname: paper-study\n";
  o.config_source = "embedded paper study";
  return o;
}

LocalStudyOptions study_file_options(const std::string& path) {
  (void)study::load_study_config(path);  // fails here, naming file:line, before anything starts
  LocalStudyOptions o;
  o.config_text = read_text_file(path, "--config", kMaxYamlBytes);
  o.config_text = study::with_named_files(o.config_text, path);  // `model: FILE`, `robot: PATH`: their content goes with it
  o.config_source = path;
  return o;
}

LocalStudyResult run_local_study(const LocalStudyOptions& opts) {
  LocalStudyResult result;
  const study::StudyConfig cfg = study::load_study_config_text(opts.config_text, opts.config_source);
  result.config = cfg;
  // A local study starts simulation workers only on a private domain: work meant for a robot would wait
  // for ever. Mixed and hardware-only studies go to a service with an agent (`study submit`).
  if (cfg.needs_hardware()) {
    const char* key = cfg.hardware.models_hardware() ? "hardware"
                      : cfg.validation.enabled       ? "validation"
                                                     : "explore_on";
    throw InputError(fmt::format("{}: {}: `study run` has simulation workers only; submit this study to an "
                                 "optimizer service with a robot agent on its domain (`cpgmatch study submit`)",
                                 opts.config_source, key));
  }
  // Read before anything starts: a missing gait file exits 2 at once.
  const std::vector<domain::EnqueuedGait> gaits = read_enqueued_gaits(opts.config_text, opts.config_source);
  if (opts.workers < 0) throw InputError("--workers must be >= 1");
  const int workers = opts.workers > 0 ? opts.workers : std::max(1u, std::thread::hardware_concurrency());
  result.workers = workers;
  // A local study is reproducible: unless the file says otherwise, it runs in lockstep with one rollout per
  // worker, so the same seed and worker count give the same study whatever order the reports arrive in.
  std::string config_text = opts.config_text;
  if (!cfg.lockstep_given) {
    std::string locked = config_text;
    if (!locked.empty() && locked.back() != '\n') locked += '\n';
    locked += fmt::format("lockstep: {}  # added by study run: {} workers\n", workers, workers);
    try {
      result.config = study::load_study_config_text(locked, opts.config_source);
      config_text = std::move(locked);
    } catch (const InputError&) {
      // A flow-style file ({name: x, ...}) cannot take an appended key: it runs asynchronously.
      fmt::print(stderr, "note: {}: could not add `lockstep: {}`; the study runs asynchronously (not reproducible)\n",
                 opts.config_source, workers);
    }
  }
  // Held until this function returns, i.e. until the study's services are stopped.
  std::optional<runtime::DomainLease> lease;
  if (opts.domain < 0) {
    lease.emplace(lease_private_domain());
  } else if (opts.domain >= 150 && opts.domain < 230) {
    // An explicit domain inside the leased range: take its lease too, so no leasing run picks it meanwhile;
    // if another local study holds it, say so (the user asked for it, so the run goes ahead).
    try {
      lease.emplace(runtime::DomainLease::acquire(opts.domain, 1, 0, runtime::DomainLease::default_lock_dir()));
    } catch (const std::runtime_error& e) {
      // Usually "in use by another local study"; the lock file may also be unusable. Either way, say why.
      fmt::print(stderr, "warning: DDS domain {} is not leased for this run: {}\n", opts.domain, e.what());
    }
  }
  const int domain = lease ? lease->domain() : opts.domain;
  dds::validate_domain(domain);
  const fs::path dir = opts.out.empty() ? timestamped_results_dir(cfg.name) : opts.out;
  fs::create_directories(dir);
  result.dir = dir;
  const std::string store = opts.store.empty() ? (dir / "study.db").string() : opts.store;
  result.store = store;

  if (!opts.quiet) {
    fmt::print(stderr, "{}study '{}': {} rollouts ({} random, then {}), {} parameters, {:.0f} s + {:.0f} s each\n",
               opts.progress_label, cfg.name, cfg.budget, cfg.optimizer.initial_points,
               bo::to_string(cfg.optimizer.acquisition), cfg.space.size(), cfg.entrain_s, cfg.eval_s);
    fmt::print(stderr, "{}optimizer service + {} simulation workers on private DDS domain {}; logs in {}\n",
               opts.progress_label, workers, domain, dir.string());
  }
  // Private by default: loopback is shared by every user of the machine, so without security any of them
  // could read the study's states and trials, pause it or forge its results. The keystore lives as long
  // as the study's services (declared before them: destroyed after they are stopped).
  std::optional<PrivateKeystore> private_keys;
  const char* given_keystore = std::getenv("CPGMATCH_KEYSTORE");
  const bool have_keystore = given_keystore != nullptr && *given_keystore != '\0';
  if (!have_keystore && !opts.insecure) {
    private_keys.emplace();
    setenv("CPGMATCH_KEYSTORE", private_keys->path().c_str(), 1);  // the children and this client use it
    if (!opts.quiet) {
      fmt::print(stderr, "{}DDS-Security with a private keystore for this run ({:.1f} s to make; removed at the end)\n",
                 opts.progress_label, private_keys->make_time_s());
    }
  } else if (!have_keystore) {
    fmt::print(stderr, "{}INSECURE (--insecure): no DDS-Security; any local user can read and steer this study\n",
               opts.progress_label);
  }
  result.secure = have_keystore || private_keys.has_value();
  // Whatever happens below, the private keystore's variable does not outlive the run (reproduce runs
  // several studies in one process, each with its own keystore).
  struct UnsetOnExit {
    bool active;
    ~UnsetOnExit() {
      if (active) unsetenv("CPGMATCH_KEYSTORE");
    }
  } unset_keystore{private_keys.has_value()};
  // Each process of the run takes its own role's enclave: a ROS 2 shell's one-for-all override would make
  // the optimizer, the workers and this client one identity, and the keystore's permissions refuse them.
  unsetenv("ROS_SECURITY_ENCLAVE_OVERRIDE");
  const fs::path bin = fs::path(self_executable()).parent_path();
  const std::string d = std::to_string(domain);
  std::vector<std::unique_ptr<ChildProcess>> children;
  children.push_back(std::make_unique<ChildProcess>(
      std::vector<std::string>{(bin / "cpgmatch-optimizer").string(), "--domain", d, "--store", store,
                               "--localhost-only", "--log-level", "warn"},
      (dir / "optimizer.log").string()));
  // Under $CPGMATCH_KEYSTORE the workers are the keystore's "worker" identity, and a worker id must be its
  // certificate's CN or CN/suffix (dds::worker_id_belongs_to): CN/local-PID-i.
  std::string id_prefix;
  if (const char* ks = std::getenv("CPGMATCH_KEYSTORE"); ks != nullptr && *ks != '\0') {
    try {
      id_prefix = dds::certificate_common_name(fs::path(ks) / "enclaves" / "worker" / "cert.pem") + "/";
    } catch (const std::exception&) {
      // The workers stop with the keystore's own message (exit 2) when they start.
    }
  }
  for (int i = 0; i < workers; ++i) {
    children.push_back(std::make_unique<ChildProcess>(
        std::vector<std::string>{(bin / "cpgmatch-sim-worker").string(), "--domain", d, "--slots", "1", "--id",
                                 fmt::format("{}local-{}-{}", id_prefix, getpid(), i), "--localhost-only", "--log-level",
                                 "warn"},
        (dir / fmt::format("worker-{}.log", i)).string()));
  }
  // Every child is asked to stop at once and all share one grace period (a worker finishing a long rollout
  // is SIGKILLed after it; its rollout process dies with it, PR_SET_PDEATHSIG): N workers one after the other
  // took N grace periods, longer than a supervisor waits after its SIGTERM.
  auto stop_all = [&] { stop_children(children, 5.0); };
  g_interrupted = 0;
  // SIGHUP too: a closed terminal or ssh session must not leave the study's processes running.
  for (const int sig : {SIGINT, SIGTERM, SIGHUP}) std::signal(sig, [](int) { g_interrupted = 1; });

  // The children take $CPGMATCH_KEYSTORE (and Fast DDS's own variables) from the environment; this process
  // must join them the same way, as the operator, or it would never hear its own optimizer.
  runtime::DdsFlags env_only;
  env_only.default_enclave = "operator";
  runtime::apply_dds_flags(env_only);
  client::StudyClient client(domain, true, /*read_trials=*/true);
  const auto start = std::chrono::steady_clock::now();
  const client::CommandResult submitted = client.submit(config_text, opts.config_source, 30.0, gaits);
  if (!submitted.ok) {
    stop_all();
    throw InputError(submitted.message);
  }
  if (g_interrupted) {  // a signal during the submission (up to 30 s)
    stop_all();
    throw std::runtime_error(fmt::format("interrupted; the study is kept in {} (resume with --store)", store));
  }
  result.study_id = submitted.study_id;
  ProgressBar bar(cfg.budget, opts.quiet, opts.progress_label);
  json state;
  int shown = -1;
  while (true) {
    if (g_interrupted) {
      stop_all();
      throw std::runtime_error(fmt::format("interrupted; the study is kept in {} (resume with --store)", store));
    }
    if (!children.front()->running()) {
      stop_all();
      throw std::runtime_error(fmt::format("the optimizer service exited; see {}", (dir / "optimizer.log").string()));
    }
    if (std::none_of(children.begin() + 1, children.end(), [](auto& c) { return c->running(); })) {
      stop_all();
      throw std::runtime_error(fmt::format("every worker exited; see {}", (dir / "worker-0.log").string()));
    }
    const auto states = client.states();
    if (auto it = states.find(submitted.study_id); it != states.end()) {
      state = it->second;
      const int done = state["completed"].get<int>();
      if (done != shown) {
        bar.update(done, state["best_cost"].is_null() ? std::nan("") : state["best_cost"].get<double>(),
                   std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
        shown = done;
      }
      if (is_terminal(state["state"].get<std::string>())) break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  result.wall_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  // Trial records travel on their own topic; give the last ones a moment to arrive.
  for (int i = 0; i < 100; ++i) {
    result.records = client.trials(submitted.study_id);
    if (static_cast<int>(result.records.size()) >= state["completed"].get<int>()) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  stop_all();
  result.state = state;
  if (state["state"] != "done") {
    throw std::runtime_error(fmt::format("study {} ended {}: {}", submitted.study_id, state["state"].get<std::string>(),
                                         state["message"].get<std::string>()));
  }
  if (const auto why = every_trial_failed(result.records)) {
    throw std::runtime_error(fmt::format("study {}: {} (results kept in {})", submitted.study_id, *why, dir.string()));
  }
  return result;
}

}  // namespace cpgmatch::cli
