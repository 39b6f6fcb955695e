// Test helper: offers one short candidate to one worker, outside any study, and prints its report.
//   offer_candidate DOMAIN WORKER TRIAL
// How tests/robot/test_agent_estop.sh checks that a latched agent refuses work and a released one takes it:
// the optimizer stops assigning to an agent that announces it is not accepting, so only a candidate
// written directly can prove the refusal. Prints {"ok":..,"error":..} and exits 0 once the report came,
// 1 when none came within 60 s.
#include <chrono>
#include <iostream>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include <nlohmann/json.hpp>

#include "cpgmatch/dds/convert.hpp"
#include "cpgmatch/dds/participant.hpp"

int main(int argc, char** argv) {
  if (argc != 4) {
    std::cerr << "usage: offer_candidate DOMAIN WORKER TRIAL\n";
    return 2;
  }
  namespace transport = cpgmatch::dds;
  namespace msg = cpgmatch::msg;
  const std::string worker = argv[2];
  const auto trial = static_cast<std::uint32_t>(std::stoul(argv[3]));
  constexpr std::uint64_t kStore = 0x6573746f70ull;  // no optimizer's store: the optimizer ignores the report
  constexpr std::uint32_t kStudy = 9999;
  transport::Participant p(transport::ParticipantConfig::basic(std::atoi(argv[1]), "candidate-offer", true));
  std::mutex mutex;
  std::optional<msg::RolloutReport> got;
  transport::Reader<msg::RolloutReport> reports(p, [&](const msg::RolloutReport& r) {
    if (r.store_id() != kStore || r.study_id() != kStudy || r.trial_id() != trial) return;
    std::lock_guard<std::mutex> lock(mutex);
    got = r;
  });
  transport::Writer<msg::Candidate> candidates(p);
  if (!candidates.matched().wait_for(1, std::chrono::seconds(20))) {
    std::cerr << "offer_candidate: no candidate reader on the domain\n";
    return 1;
  }
  msg::Candidate c;
  c.store_id(kStore);
  c.study_id(kStudy);
  c.trial_id(trial);
  c.worker_id(worker);
  c.lease_s(60.0);
  c.rollout().entrain_s(0.5);
  c.rollout().eval_s(0.5);
  c.rollout().terrain("flat");
  c.rollout().seed(1);
  msg::ParameterValue f;
  f.name("frequency");
  f.value(1.0);
  c.parameters().push_back(f);
  candidates.write(c);
  for (int i = 0; i < 600; ++i) {
    {
      std::lock_guard<std::mutex> lock(mutex);
      if (got) {
        std::cout << nlohmann::json{{"ok", got->ok()}, {"outcome", cpgmatch::domain::to_string(transport::from_wire(*got).outcome)}, {"error", got->error().to_string()}, {"worker_id", got->worker_id().to_string()}}.dump()
                  << std::endl;
        return 0;
      }
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  std::cerr << "offer_candidate: no report within 60 s\n";
  return 1;
}
