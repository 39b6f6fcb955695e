// Test helper: how many rollout reports the workers on a domain still hold for late joiners.
//   count_reports DOMAIN
// Joins the domain, lets the transient-local history of cpgmatch/reports arrive for 3 s after the first
// writer matched, and prints the number of reports received. Exits 1 when no report writer was found.
#include <atomic>
#include <chrono>
#include <cstdlib>
#include <iostream>
#include <thread>

#include "cpgmatch/dds/participant.hpp"

int main(int argc, char** argv) {
  if (argc != 2) {
    std::cerr << "usage: count_reports DOMAIN\n";
    return 2;
  }
  namespace transport = cpgmatch::dds;
  transport::ParticipantConfig config;
  config.domain = std::atoi(argv[1]);
  config.name = "report-counter";
  config.localhost_only = true;
  transport::Participant p(config);
  std::atomic<int> received{0};
  transport::Reader<cpgmatch::msg::RolloutReport> reports(p, [&](const cpgmatch::msg::RolloutReport&) { ++received; });
  if (!reports.matched().wait_for(1, std::chrono::seconds(10))) {
    std::cerr << "count_reports: no report writer on the domain\n";
    return 1;
  }
  std::this_thread::sleep_for(std::chrono::seconds(3));
  std::cout << received.load() << std::endl;
  return 0;
}
