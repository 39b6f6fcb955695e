// Commands that talk to a running optimizer service over DDS:
//   cpgmatch study submit --config STUDY.yaml [--wait] [--json]
//   cpgmatch study pause|resume|stop ID
//   cpgmatch status [--study ID] [--json]
//   cpgmatch watch [--study ID]
//   cpgmatch workers [--json]
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <csignal>
#include <fstream>
#include <iostream>
#include <sstream>
#include <thread>

#include <fmt/format.h>

#include "cpgmatch/study/robot_file.hpp"
#include "cpgmatch/study/study_config.hpp"
#include "commands.hpp"
#include "flag_checks.hpp"
#include "gait_files.hpp"
#include "cpgmatch/study/study_spec.hpp"
#include "cpgmatch/text.hpp"
#include "cpgmatch/dds/domain.hpp"
#include "service_flags.hpp"
#include "study_client.hpp"

namespace cpgmatch::cli {

namespace {

using nlohmann::json;
volatile std::sig_atomic_t g_interrupted = 0;

std::string num(const json& v, const char* format = "{:.4g}") {
  return v.is_null() ? std::string("-") : fmt::format(fmt::runtime(format), v.get<double>());
}

// Only `workers` reads the workers' announcements (see StudyClient).
client::StudyClient connect(const ServiceFlags& f, bool trials = false, bool workers = false) {
  runtime::apply_dds_flags(f.dds);
  return client::StudyClient(f.resolved_domain(), f.localhost_only, trials, workers);
}

// Waits for an optimizer's state history (`settle_s` after it is heard); a clear error (exit 1) when none is
// heard on the domain: nothing wrong with the command, the service is not there (or not reachable).
void require_optimizer(client::StudyClient& c, const ServiceFlags& f, double settle_s = 1.0) {
  if (!c.wait_for_optimizer(f.timeout_s, settle_s)) {
    throw std::runtime_error(fmt::format("no optimizer on DDS domain {} (none heard within {:g} s)", f.resolved_domain(),
                                         f.timeout_s));
  }
}

// `status --study N`: the optimizer first (none heard: exit 1, as `status`), then the study's state. Only a
// study the optimizer that answered does not have is bad input (exit 2). Its transient-local history can lag
// the match, so the study gets the rest of the timeout, and at least a second.
void require_study(client::StudyClient& c, const ServiceFlags& f, int study_id) {
  const auto start = std::chrono::steady_clock::now();
  require_optimizer(c, f, 0.0);
  const double waited = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (!c.wait_for_study(study_id, std::max(1.0, f.timeout_s - waited))) {
    throw InputError(fmt::format("--study: the optimizer on DDS domain {} has no study {}", f.resolved_domain(),
                                 study_id));
  }
}

// Waits until the study reaches a terminal state, printing progress on stderr. Returns its last state.
json wait_until_finished(client::StudyClient& c, int study_id, bool quiet) {
  std::signal(SIGINT, [](int) { g_interrupted = 1; });
  const bool tty = isatty(STDERR_FILENO);
  json last;
  std::string last_line;
  while (!g_interrupted) {
    const auto states = c.states();
    if (auto it = states.find(study_id); it != states.end()) {
      last = it->second;
      const std::string line = progress_line(last);
      if (!quiet && line != last_line) {
        fmt::print(stderr, "{}{}{}", tty ? "\r\033[K" : "", escape_message_lines(line), tty ? "" : "\n");
        last_line = line;
      }
      if (is_terminal(last["state"].get<std::string>())) break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  if (!quiet && tty) fmt::print(stderr, "\n");
  return last;
}

void print_states(const std::map<int, json>& states) {
  fmt::print("{:>5}  {:<20} {:<8} {:>13} {:>10} {:>6} {:>8} {:>8}\n", "study", "name", "state", "completed", "best cost",
             "falls", "workers", "rate/s");
  for (const auto& [id, s] : states) {
    // Names and messages come from study files and the wire: escaped like every echoed input (text.hpp).
    fmt::print("{:>5}  {:<20} {:<8} {:>13} {:>10} {:>6} {:>8} {:>8}\n", id, escape_for_message(s["name"].get<std::string>(), 64),
               s["state"].get<std::string>(), fmt::format("{}/{}", s["completed"].get<int>(), s["budget"].get<int>()),
               num(s["best_cost"]), s["falls"].get<int>(), s["workers"].get<int>(), num(s["rollouts_per_s"], "{:.1f}"));
  }
}

}  // namespace

int ServiceFlags::resolved_domain() const {
  if (domain >= 0) {
    dds::validate_domain(domain);
    return domain;
  }
  return dds::default_domain();
}

void add_service_flags(CLI::App* cmd, ServiceFlags& f, const std::string& default_enclave) {
  cmd->add_option("--domain", f.domain, "DDS domain id (default: $CPGMATCH_DOMAIN, else $ROS_DOMAIN_ID, else 0)");
  cmd->add_flag("--localhost-only", f.localhost_only, "UDP on 127.0.0.1 only (a private study on one machine)");
  cmd->add_option("--timeout", f.timeout_s, "seconds to wait for the optimizer")->capture_default_str();
  runtime::add_dds_flags(*cmd, f.dds, default_enclave);
}

bool is_terminal(const std::string& state) { return state == "done" || state == "failed" || state == "stopped"; }

// `workers` lists what this client heard; on stderr (the list on stdout stays a list) it says when that
// looks short of what is on the domain: a client on a crowded host or behind a busy discovery server can
// hear part of a fleet, or nothing, and an empty list alone reads as "no workers".
void say_if_discovery_incomplete(const client::StudyClient& c, const ServiceFlags& f, int listed) {
  const int matched = c.matched_workers();
  const std::optional<int> counted = c.optimizer_worker_count();
  const int domain = f.resolved_domain();
  if (counted && *counted > listed) {
    fmt::print(stderr,
               "cpgmatch workers: discovery looks incomplete: the optimizer counts {} live workers, this client heard "
               "{} within {:g} s (a fleet still joining, a crowded host or a busy discovery server); run again or "
               "give --timeout more\n",
               *counted, listed, std::min(f.timeout_s, 5.0));
  } else if (matched > listed) {
    fmt::print(stderr, "cpgmatch workers: discovery looks incomplete: {} workers matched, {} heard so far\n", matched,
               listed);
  } else if (listed == 0) {
    fmt::print(stderr,
               "cpgmatch workers: no worker heard on DDS domain {} within {:g} s{}: none running, or not reachable "
               "with this client's domain, --dds-profile and --discovery-server\n",
               domain, std::min(f.timeout_s, 5.0),
               counted ? fmt::format(" (the optimizer counts {} either)", *counted) : " and no optimizer heard");
  }
}

// `status` without --study: says on stderr what an empty or workerless answer means.
void say_what_status_lacks(const std::map<int, json>& states, const ServiceFlags& f) {
  if (states.empty()) {
    fmt::print(stderr, "cpgmatch status: the optimizer on DDS domain {} has no study (or its states have not "
                       "arrived yet)\n", f.resolved_domain());
    return;
  }
  for (const auto& [id, s] : states) {
    if (s.value("state", "") == "running" && s.value("workers", 0) == 0) {
      fmt::print(stderr, "cpgmatch status: study {} is running but the optimizer hears no worker: none started, or "
                         "the workers have not found it yet (discovery; see `cpgmatch workers`)\n", id);
      return;  // the workers count is the optimizer's, the same for every study
    }
  }
}

std::string progress_line(const json& s) {
  const int done = s["completed"].get<int>(), budget = s["budget"].get<int>();
  const double rate = s["rollouts_per_s"].is_null() ? 0.0 : s["rollouts_per_s"].get<double>();
  const int width = 30, filled = budget > 0 ? width * std::min(done, budget) / budget : width;
  const std::string eta = rate > 0 ? fmt::format("{:.0f}s", (budget - done) / rate) : std::string("-");
  return fmt::format("study {} [{}{}] {:>4}/{} best {:<9} {:6.2f} rollouts/s  eta {:>5}  workers {}  {}",
                     s["study_id"].get<int>(), std::string(filled, '#'), std::string(width - filled, '.'), done, budget,
                     num(s["best_cost"]), rate, eta, s["workers"].get<int>(), s["state"].get<std::string>()) +
         // A running study whose work waits says for what: no simulation worker on the domain, a robot under an
         // emergency stop, a hardware phase without a robot (docs/dds.md, StudyState.message).
         (s["state"].get<std::string>() == "running" && s.value("message", "").rfind("waiting", 0) == 0
              ? "  (" + s.value("message", "") + ")"
              : std::string());
}

void add_study_service_commands(CLI::App* study) {
  {
    struct Options {
      ServiceFlags service;
      std::string config;
      bool wait = false, json = false, quiet = false;
    };
    auto o = std::make_shared<Options>();
    CLI::App* cmd = study->add_subcommand("submit", "submit a study file to the optimizer service; prints its id");
    cmd->add_option("--config", o->config, "study YAML")->required();
    cmd->add_flag("--wait", o->wait, "wait until the study has finished, showing progress");
    cmd->add_flag("--json", o->json, "print the result as JSON");
    cmd->add_flag("--quiet", o->quiet, "no progress output");
    add_service_flags(cmd, o->service, "operator");
    cmd->callback([o] {
      // `model: FILE` and `robot: PATH` in the study: the files' content goes with it (robot_file.hpp).
      const std::string text = study::with_named_files(read_text_file(o->config, "--config"), o->config);
      if (text.size() > study::kMaxStudyFileBytes) {
        throw InputError(fmt::format("--config {}: {} bytes, more than a study file may have ({} bytes)", o->config,
                                     text.size(), study::kMaxStudyFileBytes));
      }
      // Checked here first, with the same rules as the service: a bad file exits 2 at once, naming the
      // field and line, without waiting for an optimizer (which would refuse it the same way).
      (void)study::StudySpec::resolve(text, o->config, study::SpecDefaults::shipped());
      // `enqueue:` files are read here, relative to the study file: the service receives their values.
      const std::vector<domain::EnqueuedGait> gaits = read_enqueued_gaits(text, o->config);
      client::StudyClient c = connect(o->service);
      const client::CommandResult r = c.submit(text, o->config, o->service.timeout_s, gaits);
      if (!r.ok) throw InputError(r.message);  // e.g. "study.yaml:4: budget: must be >= 1"
      if (!o->wait) {
        if (o->json) std::cout << json{{"study_id", r.study_id}, {"message", r.message}}.dump() << std::endl;
        else std::cout << r.study_id << std::endl;
        return;
      }
      const json last = wait_until_finished(c, r.study_id, o->quiet);
      if (o->json) std::cout << last.dump() << std::endl;
      else fmt::print("study {}: {} ({})\n", r.study_id, last.value("state", "unknown"), escape_message_lines(last.value("message", "")));
      if (last.is_null() || last["state"] != "done") throw std::runtime_error("study did not finish");
    });
  }
  for (const char* kind : {"pause", "resume", "stop"}) {
    struct Options {
      ServiceFlags service;
      int study_id = 0;
    };
    auto o = std::make_shared<Options>();
    CLI::App* cmd = study->add_subcommand(kind, fmt::format("{} a study on the optimizer service", kind));
    cmd->add_option("id", o->study_id, "study id")->required()->check(study_id());
    add_service_flags(cmd, o->service, "operator");
    const std::string k = kind;
    cmd->callback([o, k] {
      client::StudyClient c = connect(o->service);
      const client::CommandResult r = c.control(k, o->study_id, o->service.timeout_s);
      if (!r.ok) throw InputError(r.message);
      fmt::print("{}\n", escape_message_lines(r.message));
    });
  }
}

void add_service_commands(CLI::App& app) {
  {
    struct Options {
      ServiceFlags service;
      int study_id = -1;
      bool json = false;
    };
    auto o = std::make_shared<Options>();
    CLI::App* cmd = app.add_subcommand("status", "studies on the optimizer service");
    cmd->add_option("--study", o->study_id, "only this study")->check(study_id());
    cmd->add_flag("--json", o->json, "JSON: one object with --study, else an array");
    add_service_flags(cmd, o->service, "viewer");
    cmd->callback([o] {
      client::StudyClient c = connect(o->service);
      if (o->study_id >= 0) {
        require_study(c, o->service, o->study_id);
      } else {
        require_optimizer(c, o->service);
      }
      auto states = c.states();
      if (o->study_id < 0) say_what_status_lacks(states, o->service);
      if (o->study_id >= 0) {
        const auto it = states.find(o->study_id);
        if (it == states.end()) throw InputError(fmt::format("--study: no study {}", o->study_id));
        if (o->json) std::cout << it->second.dump() << std::endl;
        else print_states({*it});
        return;
      }
      if (o->json) {
        json all = json::array();
        for (const auto& [id, s] : states) all.push_back(s);
        std::cout << all.dump() << std::endl;
      } else {
        print_states(states);
      }
    });
  }
  {
    struct Options {
      ServiceFlags service;
      int study_id = -1;
    };
    auto o = std::make_shared<Options>();
    CLI::App* cmd = app.add_subcommand("watch", "stream study progress until the studies finish (Ctrl-C to leave)");
    cmd->add_option("--study", o->study_id, "only this study")->check(study_id());
    add_service_flags(cmd, o->service, "viewer");
    cmd->callback([o] {
      client::StudyClient c = connect(o->service);
      require_optimizer(c, o->service);
      std::signal(SIGINT, [](int) { g_interrupted = 1; });
      std::map<int, std::string> last;
      while (!g_interrupted) {
        bool open = false;
        for (const auto& [id, s] : c.states()) {
          if (o->study_id >= 0 && id != o->study_id) continue;
          const std::string line = progress_line(s);
          if (last[id] != line) fmt::print("{}\n", escape_message_lines(line));
          last[id] = line;
          open = open || !is_terminal(s["state"].get<std::string>());
        }
        std::fflush(stdout);
        if (!open) break;
        std::this_thread::sleep_for(std::chrono::milliseconds(250));
      }
    });
  }
  {
    struct Options {
      ServiceFlags service;
      bool json = false;
    };
    auto o = std::make_shared<Options>();
    CLI::App* cmd = app.add_subcommand("workers", "live workers on the domain");
    cmd->add_flag("--json", o->json, "JSON array");
    add_service_flags(cmd, o->service, "viewer");
    cmd->callback([o] {
      client::StudyClient c = connect(o->service, false, /*workers=*/true);
      // Discovery takes a moment: wait for the workers themselves (not for an optimizer, which a worker list
      // does not need), or `workers` listed none of a worker that heartbeats in 3 of 26 tries.
      c.wait_for_workers(std::min(o->service.timeout_s, 5.0));
      const auto workers = c.workers();
      say_if_discovery_incomplete(c, o->service, static_cast<int>(workers.size()));
      if (o->json) {
        json all = json::array();
        for (const auto& [id, w] : workers) all.push_back(w);
        std::cout << all.dump() << std::endl;
        return;
      }
      fmt::print("{:<24} {:<8} {:<16} {:>7} {:>6} {:>5} {:>10}\n", "worker", "kind", "host", "pid", "slots", "busy", "completed");
      for (const auto& [id, w] : workers) {
        fmt::print("{:<24} {:<8} {:<16} {:>7} {:>6} {:>5} {:>10}\n", escape_for_message(id, 64), w["kind"].get<std::string>(),
                   escape_for_message(w["host"].get<std::string>(), 64), w["pid"].get<int>(), w["slots"].get<int>(), w["busy"].get<int>(),
                   w["completed"].get<int>());
      }
    });
  }
}

}  // namespace cpgmatch::cli
