// cpgmatch-robot-agent: the robot's worker. Joins a study's DDS domain as a worker of kind hardware with
// capacity 1 and runs each candidate on the robot through the CAN bus, with the same controller,
// feedback, contact sensing and cost code as the simulation (common/), returning the same reports.
//
//   cpgmatch-robot-agent --domain 7 --can socketcan:can0 [--robot ROBOT.yaml] [--id morti]
//                        [--dds-profile local|cluster|FILE] [--discovery-server IP:PORT] [--keystore DIR --enclave NAME]
//   cpgmatch-robot-agent --can udp:127.0.0.1:47000 --run-once [--params F] [--entrain S] [--eval S] [--json]
//
// --run-once runs one rollout without DDS and prints it (JSON: the report's fields plus the loop's
// jitter), for bring-up and benchmarks. SIGINT/SIGTERM: the running rollout stops safely at once (motors
// to the safe state, then off), its report says so, and the agent leaves the domain. A stop on the
// cpgmatch/estop topic (cpgmatch estop) does the same but latches: the agent stays on the domain, announces
// that it does not accept work and refuses candidates until a release (docs/robot_agent.md).
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <chrono>
#include <csignal>
#include <iostream>
#include <optional>
#include <thread>

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include "cpgmatch/dds/convert.hpp"
#include "cpgmatch/dds/domain.hpp"
#include "cpgmatch/domain/report_json.hpp"
#include "cpgmatch/dds/security.hpp"
#include "cpgmatch/errors.hpp"
#include "cpgmatch/robot_description_loader.hpp"
#include "cpgmatch/runtime/install_layout.hpp"
#include "cpgmatch/runtime/man_pages.hpp"
#include "cpgmatch/runtime/shared_flags.hpp"
#include "cpgmatch/worker/candidate_queue.hpp"
#include "cpgmatch/worker/spec_book.hpp"
#include "cpgmatch/worker/worker_link.hpp"
#include "hardware_runner.hpp"
#include "trace_sender.hpp"

namespace cpgmatch::robot {
namespace {

volatile std::sig_atomic_t g_stop = 0;
void on_signal(int) { g_stop = 1; }

struct Options {
  int domain = -1;
  std::string id;
  std::string can_uri;
  std::string robot_path;
  std::string settings_path;
  std::string params_path;
  double entrain_s = -1.0;
  double eval_s = -1.0;
  std::uint64_t seed = 0;
  bool run_once = false;
  bool json = false;
  bool localhost_only = false;
  bool no_realtime = false;
  bool lockstep = false;
  bool insecure = false;
  double heartbeat_s = 0.5;
};

// The shipped configs: $CPGMATCH_CONFIG_DIR, else an installed prefix's, else the source tree's.
std::string config_path(const std::string& relative) { return (runtime::config_dir() / relative).string(); }

domain::Outcome outcome_of(const HardwareRollout& h) {
  switch (h.outcome) {
    case HardwareOutcome::kRan: return domain::outcome_of(h.result.outcome);
    case HardwareOutcome::kRefused: return domain::Outcome::kRefused;
    case HardwareOutcome::kPlantFault: return domain::Outcome::kPlantFault;
    case HardwareOutcome::kError: return domain::Outcome::kError;
  }
  return domain::Outcome::kError;
}

domain::RolloutReport to_report(const HardwareRollout& h) {
  domain::RolloutReport r;
  if (h.ok) {
    r = domain::report_of(h.result);
  } else {
    r.outcome = outcome_of(h);
    r.error = h.error;
  }
  r.worker_kind = domain::WorkerKind::kHardware;
  r.loop.jitter_p50_us = h.loop.jitter_p50_us;
  r.loop.jitter_p99_us = h.loop.jitter_p99_us;
  r.loop.jitter_max_us = h.loop.jitter_max_us;
  r.loop.overruns = static_cast<int>(std::min<std::uint64_t>(h.loop.overruns, INT32_MAX));
  return r;
}

nlohmann::json loop_json(const HardwareRollout& h) {
  return {{"ticks", h.loop.ticks},
          {"jitter_p50_us", h.loop.jitter_p50_us},
          {"jitter_p99_us", h.loop.jitter_p99_us},
          {"jitter_max_us", h.loop.jitter_max_us},
          {"overruns", h.loop.overruns},
          {"feedback_latency_p50_us", h.loop.feedback_latency_p50_us},
          {"feedback_latency_p99_us", h.loop.feedback_latency_p99_us},
          {"feedback_latency_max_us", h.loop.feedback_latency_max_us},
          {"missing_replies", h.loop.missing_replies},
          {"unexpected_frames", h.loop.unexpected_frames},
          {"cpu_s", h.cpu_s}};
}

std::string loop_summary(const HardwareRollout& h) {
  return fmt::format(
      "loop {} ticks, jitter p50 {:.0f} us p99 {:.0f} us max {:.0f} us, {} overruns, feedback latency p50 {:.0f} us p99 "
      "{:.0f} us, {} missing replies, cpu {:.2f} s",
      h.loop.ticks, h.loop.jitter_p50_us, h.loop.jitter_p99_us, h.loop.jitter_max_us, h.loop.overruns,
      h.loop.feedback_latency_p50_us, h.loop.feedback_latency_p99_us, h.loop.missing_replies, h.cpu_s);
}

// Stops the running rollout when a signal arrives (a signal handler may not touch the bus itself).
class SignalWatch {
 public:
  explicit SignalWatch(HardwareRunner& runner)
      : thread_([this, &runner] {
          while (!done_) {
            if (g_stop && !fired_) {
              runner.emergency_stop("SIGINT/SIGTERM");
              fired_ = true;
            }
            std::this_thread::sleep_for(std::chrono::milliseconds(1));
          }
        }) {}
  ~SignalWatch() {
    done_ = true;
    thread_.join();
  }

 private:
  std::atomic<bool> done_{false};
  bool fired_ = false;
  std::thread thread_;
};

// --run-once has no study to bring the robot's legs and gaits: they come from the robot description the
// hardware file names (a hexapod's six legs walk its default gait). A file that names none drives Morti's four.
RolloutSettings with_robot_legs(RolloutSettings settings, const HardwareRunner& runner, const std::string& hardware_path) {
  if (!runner.robot_description().empty()) {
    apply_robot_legs(settings.controller, load_robot(runner.robot_description()));
  } else if (static_cast<std::size_t>(runner.leg_count()) != settings.controller.legs.size()) {
    throw InputError(fmt::format("{}: {} legs, and no `robot:` names the robot description whose legs and gaits "
                                 "--run-once should walk (Morti's four otherwise)",
                                 hardware_path, runner.leg_count()));
  }
  return settings;
}

int run_once(const Options& o, HardwareRunner& runner, const RolloutSettings& settings, const CpgParameters& params) {
  SignalWatch watch(runner);
  const HardwareRollout h = runner.run(params, settings, o.seed);
  if (!runner.realtime_warning().empty()) spdlog::warn("{}", runner.realtime_warning());
  if (o.json) {
    nlohmann::json j = domain::to_json(to_report(h));
    j["loop"] = loop_json(h);  // the report's loop fields and more
    j["sim_time_s"] = h.result.sim_time_s;
    std::cout << j.dump() << std::endl;
  } else if (h.ok) {
    fmt::print("cost {:.4f}{}; {}\n", h.result.cost, h.result.fell ? fmt::format(" (fell at {:.2f} s)", h.result.fall_time_s) : "",
               loop_summary(h));
  } else {
    fmt::print("failed: {}; {}\n", h.error, loop_summary(h));
  }
  if (!h.ok && h.error.rfind("refused:", 0) == 0) return kExitBadInput;
  return h.ok ? kExitOk : kExitFailure;
}

// The DDS worker: one rollout at a time on its own thread (the real-time thread). Candidates, reports
// (released once the optimizer acknowledges them) and heartbeats are the WorkerLink every worker shares;
// running a candidate on the robot is this class's own.
class HardwareWorker {
 public:
  HardwareWorker(const Options& o, HardwareRunner& runner)
      : options_(o),
        runner_(runner),
        queue_(o.id),
        link_(worker::WorkerLinkConfig{o.domain, o.id, "cpgmatch-robot-agent " + o.id, o.localhost_only,
                                       domain::WorkerKind::kHardware, 1, o.heartbeat_s, host_name(),
                                       [this](const domain::EmergencyStop& s) { on_emergency_stop(s); },
                                       static_cast<int>(study::kObjectiveVersion)},
              queue_),
        specs_(link_, static_cast<int>(study::kObjectiveVersion)),
        traces_(link_.participant()) {
    rollout_thread_ = std::thread([this] { rollout_loop(); });
  }

  void run() {
    spdlog::info("robot agent {} on domain {}: hardware worker, capacity 1", options_.id, options_.domain);
    SignalWatch watch(runner_);
    link_.heartbeat_until([] { return g_stop != 0; });
    queue_.drain();
    rollout_thread_.join();
    traces_.drain(std::chrono::seconds(5));
    link_.leave();
    spdlog::info("robot agent {}: {} rollouts done, bye", options_.id, queue_.load().completed);
  }

 private:
  static std::string host_name() {
    char host[256] = "robot";
    gethostname(host, sizeof(host) - 1);
    return host;
  }

  // On a DDS thread. The runner does the safety part (latch, safe state); this only translates and tells.
  void on_emergency_stop(const domain::EmergencyStop& s) {
    const StopOutcome outcome = runner_.stop_command(StopRequest{s.target, s.reason, s.release});
    if (outcome == StopOutcome::kNotForThisRobot) return;
    const std::optional<std::string> latched = runner_.latched_stop();
    // Announced at once, with the reason: the optimizer stops assigning to this robot, re-issues the rollout
    // the stop interrupted once it is released, and says in the study's state why it waits.
    link_.set_accepting(!latched, latched ? fmt::format("emergency-stopped ({})", *latched) : std::string());
    if (latched) {
      spdlog::warn("EMERGENCY STOP {:016x} from {} ({}): {}; motors in the safe state, refusing candidates until "
                   "`cpgmatch estop --release` or a restart",
                   s.stop_id, s.sender, to_string(outcome), *latched);
    } else {
      spdlog::warn("emergency stop {:016x} from {}: {}; accepting candidates again", s.stop_id, s.sender, to_string(outcome));
    }
  }

  // The report first, then its trace (the report never waits on the trace; TraceSender sends it).
  void rollout_loop() {
    while (const std::optional<domain::Candidate> c = queue_.take()) {
      std::optional<domain::RolloutTrace> trace;
      link_.publish(execute(*c, trace));
      if (trace) traces_.send(std::move(*trace));
      queue_.finish(*c);
    }
  }

  // Runs a candidate; `trace` gets what the robot did when the rollout ran.
  domain::RolloutReport execute(const domain::Candidate& c, std::optional<domain::RolloutTrace>& trace) {
    const auto start = std::chrono::steady_clock::now();
    HardwareRollout h;
    if (auto why = domain::check_parameters(c.parameters)) {
      h.error = "bad parameters: " + *why;
    } else if (std::optional<HardwareRollout> refused = runner_.latched_refusal()) {
      h = std::move(*refused);  // before any spec is looked at; the optimizer re-issues it after the release
    } else if (const worker::SpecBook::Lookup spec = specs_.find(c.spec_key); !spec.spec) {
      h.error = "refused: " + spec.refusal;
      h.outcome = HardwareOutcome::kRefused;
    } else if (const std::string& wanted = spec.spec->config().robot; !wanted.empty() && !domain::worker_id_belongs_to(options_.id, wanted)) {
      h.error = fmt::format("refused: the study is for robot '{}'; this agent is '{}'", wanted, options_.id);
      h.outcome = HardwareOutcome::kRefused;
    } else if (const std::optional<std::string> other_body =
                   spec.spec->robot() ? runner_.study_robot_mismatch(*spec.spec->robot()) : std::nullopt) {
      // Its id may be the study's robot's while its body is another's (a hardware file of another robot).
      h.error = "refused: " + *other_body;
      h.outcome = HardwareOutcome::kRefused;
    } else {
      // The study's spec: its controller, feedback, contact sensing, cost and base parameters (the robot's
      // own control rate and limits stay the robot's, HardwareRunner).
      CpgParameters params = spec.spec->base_parameters();
      RolloutSettings settings = spec.spec->rollout_settings();
      try {
        for (const auto& [name, value] : c.parameters) set_parameter(params, name, value, "candidate");
        settings.entrain_s = c.rollout.entrain_s;
        settings.eval_s = c.rollout.eval_s;
        if (!(settings.entrain_s >= 0.0 && settings.eval_s > 0.0 && settings.entrain_s + settings.eval_s <= 600.0)) {
          throw InputError(fmt::format("rollout length entrain {} s + eval {} s must be in (0, 600] s", settings.entrain_s, settings.eval_s));
        }
        spdlog::info("study {} trial {}: rollout on the robot ({} + {} s)", c.id.study_id, c.id.trial_id, settings.entrain_s, settings.eval_s);
        h = runner_.run(params, settings, c.rollout.seed);
        if (h.ok) {
          trace = domain::RolloutTrace{c.id, options_.id, runner_.control_rate_hz(), c.rollout.terrain, c.rollout.seed,
                                       to_map(params), h.trace_ticks_dropped, std::move(h.trace)};
        }
      } catch (const std::exception& e) {
        h.ok = false;
        h.error = e.what();
      }
    }
    if (!runner_.realtime_warning().empty() && !warned_) {
      spdlog::warn("{}", runner_.realtime_warning());
      warned_ = true;
    }
    if (h.ok) {
      spdlog::info("study {} trial {}: cost {:.4f}{}; {}", c.id.study_id, c.id.trial_id, h.result.cost, h.result.fell ? " (fell)" : "", loop_summary(h));
    } else {
      spdlog::warn("study {} trial {}: {}; {}", c.id.study_id, c.id.trial_id, h.error, loop_summary(h));
    }
    domain::RolloutReport r = to_report(h);
    r.id = c.id;  // with its store: the optimizer counts only reports of its own store
    r.worker_id = options_.id;
    r.wall_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return r;
  }

  Options options_;
  HardwareRunner& runner_;
  bool warned_ = false;
  worker::CandidateQueue queue_;
  worker::WorkerLink link_;  // after the queue: its readers feed the queue from the moment it exists
  worker::SpecBook specs_;
  TraceSender traces_;  // after the link: it writes on the link's participant
  std::thread rollout_thread_;
};

}  // namespace
}  // namespace cpgmatch::robot

int main(int argc, char** argv) {
  using namespace cpgmatch;
  using namespace cpgmatch::robot;
  CLI::App app{"cpgmatch-robot-agent: runs study candidates on the robot over its CAN bus"};
  Options o;
  app.add_option("--can", o.can_uri, "bus URI: socketcan:IFACE, udp:HOST:PORT or virtual:NAME")->required();
  app.add_option("--robot", o.robot_path, "robot YAML (default: configs/robot/morti.yaml)");
  app.add_option("--domain", o.domain, "DDS domain id (default: $CPGMATCH_DOMAIN, else $ROS_DOMAIN_ID, else 0)");
  app.add_option("--id", o.id,
                 "worker id, unique on the domain (default: HOST-robot; with --keystore the certificate's CN, and an id "
                 "must be CN or CN/SUFFIX)");
  app.add_option("--settings", o.settings_path,
                 "--run-once: rollout settings YAML (default: configs/rollout.yaml; a study brings its own)");
  app.add_flag("--localhost-only", o.localhost_only, "DDS over UDP on 127.0.0.1 only");
  app.add_flag("--no-realtime", o.no_realtime, "do not ask for SCHED_FIFO and locked memory");
  app.add_flag("--lockstep", o.lockstep,
               "with cpgmatch-robot-emulator --lockstep only: wait for every reply, even past a deadline "
               "(needs an emulator_only robot YAML)");
  app.add_flag("--run-once", o.run_once, "run one rollout without DDS and print it");
  app.add_flag("--insecure", o.insecure,
               "join the domain without DDS-Security: anyone who reaches it can send this robot rollouts and "
               "release its emergency stop (default: refuse to start without --keystore)");
  app.add_option("--params", o.params_path, "--run-once: parameter YAML (default: configs/params/default.yaml)");
  app.add_option("--entrain", o.entrain_s, "--run-once: entrainment seconds (default: the settings')");
  app.add_option("--eval", o.eval_s, "--run-once: evaluation seconds (default: the settings')");
  app.add_option("--seed", o.seed, "--run-once: seed of the contact-sensor noise");
  app.add_flag("--json", o.json, "--run-once: one JSON object");
  // The same DDS flags as every other participant; the robot agent is a worker in a study's keystore
  // (deploy/make-study-pki.sh KEYSTORE morti:worker, then --enclave morti). --run-once uses no DDS.
  runtime::DdsFlags dds_flags;
  runtime::add_dds_flags(app, dds_flags, "worker");
  runtime::add_version_flag(app, "cpgmatch-robot-agent");
  runtime::add_man_page_flag(app, "cpgmatch-robot-agent");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? kExitOk : kExitBadInput;
  }
  spdlog::set_default_logger(spdlog::stderr_color_mt("agent"));
  return run_reporting_errors([&] {
    runtime::export_config_dir();
    if (o.robot_path.empty()) o.robot_path = config_path("robot/morti.yaml");
    if (o.settings_path.empty()) o.settings_path = config_path("rollout.yaml");
    if (o.params_path.empty()) o.params_path = config_path("params/default.yaml");
    RolloutSettings settings = load_rollout_settings(o.settings_path);
    const CpgParameters params = load_parameters(o.params_path);
    if (o.entrain_s >= 0.0) settings.entrain_s = o.entrain_s;
    if (o.eval_s >= 0.0) settings.eval_s = o.eval_s;
    if (!(settings.eval_s > 0.0)) throw InputError("--eval must be > 0");
    if (!o.run_once) {
      // Flags are checked before the bus opens (a cluster profile without servers only when the participant
      // is made, still before any motor is enabled): bad input never gets as far as the motors.
      runtime::apply_dds_flags(dds_flags);
      if (o.domain < 0) o.domain = cpgmatch::dds::default_domain();
      cpgmatch::dds::validate_domain(o.domain);
      {
        char host[256] = "host";
        gethostname(host, sizeof(host) - 1);
        o.id = runtime::resolve_worker_id(o.id, fmt::format("{}-robot", host));  // with --keystore: its CN
      }
      // A robot moves on what arrives over DDS: without authentication and permissions anyone on the
      // domain could drive it or release its emergency stop. Secure is the default; insecure is said aloud.
      if (cpgmatch::dds::selected_enclave().empty()) {
        if (!o.insecure) {
          throw InputError(
              "--keystore: a robot agent needs DDS-Security (a keystore from deploy/make-study-pki.sh, e.g. "
              "`make-study-pki.sh KEYSTORE morti:worker` then --keystore KEYSTORE --enclave morti); without it anyone "
              "on the domain can send this robot rollouts and release its emergency stop. Pass --insecure to run "
              "without it anyway (a bench with no network, an emulator)");
        }
        spdlog::warn("INSECURE: no DDS-Security (--insecure): any participant on domain {} can send this robot rollouts "
                     "and release its emergency stop",
                     o.domain);
      }
      if (o.id.size() > 63) throw InputError(fmt::format("--id: at most 63 characters, got {}", o.id.size()));
      if (o.id.find('\'') != std::string::npos) throw InputError("--id must not contain a quote");
    }
    std::signal(SIGINT, on_signal);
    std::signal(SIGTERM, on_signal);
    HardwareRunnerOptions ro;
    ro.can_uri = o.can_uri;
    ro.robot_path = o.robot_path;
    ro.realtime = !o.no_realtime;
    ro.lockstep = o.lockstep;
    ro.robot_id = o.id;
    HardwareRunner runner(ro);
    if (o.run_once) return run_once(o, runner, with_robot_legs(settings, runner, o.robot_path), params);
    HardwareWorker worker(o, runner);  // each study's spec brings its settings and base parameters
    worker.run();
    return kExitOk;
  });
}
