// `cpgmatch estop [--robot ID | --all] [--reason TEXT] [--release]`: an emergency stop for robot agents
// on the cpgmatch/estop topic (docs/robot_agent.md). The agent latches it: motors safe at once, the
// running rollout fails with the reason, candidates refused until `--release`. The topic is volatile,
// so this waits for an agent's reader to match before writing and for the readers' acknowledgements after.
#include <unistd.h>

#include <chrono>
#include <iostream>
#include <random>
#include <thread>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "cpgmatch/dds/participant.hpp"
#include "service_flags.hpp"

namespace cpgmatch::cli {

namespace {

struct EstopOptions {
  ServiceFlags service;
  std::string robot;
  bool all = false;
  std::string reason;
  bool release = false;
  bool json = false;
};

// Bad input exits 2 naming the flag, before anything joins the domain.
void check(const EstopOptions& o) {
  if (o.all && !o.robot.empty()) throw InputError("--robot/--all: give one of them, not both");
  if (!o.all && o.robot.empty()) throw InputError("--robot/--all: name the robot to stop (--robot ID) or stop every robot (--all)");
  if (!o.all && (o.robot.size() > 63 || o.robot == "*")) {
    throw InputError(fmt::format("--robot: '{}' is not a worker id (1-63 characters; use --all for every robot)", o.robot));
  }
  if (o.reason.size() > 127) throw InputError(fmt::format("--reason: at most 127 bytes, got {}", o.reason.size()));
  if (!(o.service.timeout_s > 0.0 && o.service.timeout_s <= 3600.0)) {
    throw InputError(fmt::format("--timeout: {} s must be in (0, 3600]", o.service.timeout_s));
  }
}

double unix_now_s() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

void send(const EstopOptions& o) {
  runtime::apply_dds_flags(o.service.dds);
  const int domain = o.service.resolved_domain();
  dds::Participant participant(dds::ParticipantConfig::basic(domain, "cpgmatch-estop", o.service.localhost_only));
  dds::Writer<msg::EmergencyStop> writer(participant);
  const auto timeout = std::chrono::milliseconds(std::llround(o.service.timeout_s * 1000));
  if (!writer.matched().wait_for(1, timeout)) {
    throw std::runtime_error(fmt::format("no robot agent on DDS domain {} subscribes to emergency stops (waited {:.0f} s); "
                                         "nothing was sent",
                                         domain, o.service.timeout_s));
  }
  // With --all, other agents' readers may match a moment after the first.
  if (o.all) std::this_thread::sleep_for(std::chrono::milliseconds(300));
  msg::EmergencyStop s;
  s.stop_id(std::random_device{}() * 0x100000000ull + std::random_device{}());
  s.target(o.all ? "*" : o.robot);
  s.release(o.release);
  s.reason(o.reason);
  char host[64] = "host";
  gethostname(host, sizeof(host) - 1);
  s.sender(fmt::format("{}:{}", host, getpid()).substr(0, 63));
  const double sent = unix_now_s();
  if (!writer.write(s)) throw std::runtime_error("emergency stop: the DDS write failed");
  const bool acknowledged = writer.wait_for_acknowledgments(timeout);
  const int readers = writer.matched().count();
  if (o.json) {
    std::cout << nlohmann::json{{"stop_id", fmt::format("{:016x}", s.stop_id())}, {"target", s.target().to_string()},
                                {"release", o.release}, {"reason", o.reason}, {"domain", domain},
                                {"sent_unix_s", sent}, {"readers", readers}, {"acknowledged", acknowledged}}
                     .dump()
              << std::endl;
  } else {
    fmt::print("{} {:016x} sent to {} on domain {}: {} agent(s) {}\n", o.release ? "release" : "emergency stop", s.stop_id(),
               o.all ? "every robot" : o.robot, domain, readers, acknowledged ? "acknowledged" : "matched, not all acknowledged");
  }
  if (!acknowledged) throw std::runtime_error("not every agent acknowledged the emergency stop in time");
}

}  // namespace

void add_estop_command(CLI::App& app) {
  auto o = std::make_shared<EstopOptions>();
  CLI::App* cmd = app.add_subcommand("estop", "emergency stop (latched) or release for robot agents on the domain");
  cmd->add_option("--robot", o->robot, "the robot agent's worker id (its --id)");
  cmd->add_flag("--all", o->all, "every robot agent on the domain");
  cmd->add_option("--reason", o->reason, "why (at most 127 bytes); the failed reports quote it");
  cmd->add_flag("--release", o->release, "lift a latched stop: the agent accepts candidates again");
  cmd->add_flag("--json", o->json, "print what was sent as JSON (stop_id, sent_unix_s, readers, ...)");
  add_service_flags(cmd, o->service, "operator");
  cmd->get_option("--timeout")->description("seconds to wait for an agent to hear the stop, and for its acknowledgement");
  cmd->callback([o] {
    check(*o);
    send(*o);
  });
}

}  // namespace cpgmatch::cli
