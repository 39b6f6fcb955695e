// Test helper: publishes malformed samples on a domain, the way a buggy or hostile participant might.
//   inject_malformed DOMAIN STUDY_ID TARGET_WORKER
// Every sample here must be rejected (optimizer) or answered with a failed report (worker), and
// neither process may crash. Prints what it sent; exits 0 once everything was written.
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <iostream>
#include <thread>

#include "cpgmatch/dds/convert.hpp"
#include "cpgmatch/dds/participant.hpp"

using namespace std::chrono_literals;
namespace transport = cpgmatch::dds;
namespace msg = cpgmatch::msg;

int main(int argc, char** argv) {
  if (argc != 4) {
    std::cerr << "usage: inject_malformed DOMAIN STUDY_ID TARGET_WORKER\n";
    return 2;
  }
  const int domain = std::atoi(argv[1]);
  const auto study = static_cast<std::uint32_t>(std::atoi(argv[2]));
  const std::string target = argv[3];
  transport::Participant p(transport::ParticipantConfig::basic(domain, "malformed-injector", true));
  transport::Writer<msg::RolloutReport> reports(p);
  transport::Writer<msg::WorkerAnnouncement> workers(p);
  transport::Writer<msg::Candidate> candidates(p);
  transport::Writer<msg::StudyCommand> commands(p);
  if (!reports.matched().wait_for(1, 10s) || !candidates.matched().wait_for(1, 10s) ||
      !commands.matched().wait_for(1, 10s) || !workers.matched().wait_for(1, 10s)) {
    std::cerr << "inject_malformed: nobody to talk to on domain " << domain << "\n";
    return 1;
  }
  auto report = [&](std::uint32_t study_id, std::uint32_t trial, double cost, const char* what) {
    msg::RolloutReport r;
    r.study_id(study_id);
    r.trial_id(trial);
    r.worker_id("injector");
    r.ok(true);
    r.cost(cost);
    reports.write(r);
    std::cout << "sent report: " << what << std::endl;
  };
  report(study, 0, std::nan(""), "NaN cost");
  report(999, 0, 1.0, "unknown study");
  report(study, 100000, 1.0, "candidate never issued");

  msg::WorkerAnnouncement w;
  w.worker_id("impostor");
  w.worker_key(12345);  // not the hash of the id
  w.slots(4);
  workers.write(w);
  std::cout << "sent worker announcement: key does not match id" << std::endl;

  msg::StudyCommand bad_submit;
  bad_submit.correlation_id(1);
  bad_submit.client_id("injector");
  bad_submit.kind(msg::COMMAND_SUBMIT);
  bad_submit.study_yaml("name: bad\nparameters:\n  - {name: no_such_parameter, low: 0, high: 1}\n");
  bad_submit.source_name("injected.yaml");
  commands.write(bad_submit);
  msg::StudyCommand not_yaml = bad_submit;
  not_yaml.correlation_id(2);
  not_yaml.study_yaml("{{{ not yaml");
  commands.write(not_yaml);
  msg::StudyCommand unknown_stop;
  unknown_stop.correlation_id(3);
  unknown_stop.client_id("injector");
  unknown_stop.kind(msg::COMMAND_STOP);
  unknown_stop.study_id(4242);
  commands.write(unknown_stop);
  std::cout << "sent commands: bad parameter name, not YAML, stop of an unknown study" << std::endl;

  msg::Candidate c;
  c.study_id(777);
  c.trial_id(1);
  c.worker_id(target);
  c.lease_s(10);
  msg::RolloutSpec spec;
  spec.entrain_s(0.5);
  spec.eval_s(0.5);
  spec.terrain("flat");
  c.rollout(spec);
  c.parameters(transport::to_wire({{"frequency", std::nan("")}, {"hip_amplitude", 0.4}}));
  candidates.write(c);
  c.trial_id(2);
  c.parameters(transport::to_wire({{"frequency", 1.0}}));
  spec.terrain("lava:3");
  c.rollout(spec);
  candidates.write(c);
  std::cout << "sent candidates to " << target << ": NaN frequency, unknown terrain" << std::endl;
  std::this_thread::sleep_for(1s);  // let reliable delivery finish before the participant goes
  return 0;
}
