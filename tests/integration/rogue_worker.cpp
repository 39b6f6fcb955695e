// Test helper: a worker that cheats, the way a participant holding a valid worker certificate might.
//   rogue_worker DOMAIN KEYSTORE|- ENCLAVE OWN_ID SLOTS VICTIM_ID SECONDS
// For SECONDS it
//  * announces itself as OWN_ID with SLOTS slots every 0.5 s, takes the candidates sent to OWN_ID and never
//    answers them (a slot count it does not honour);
//  * announces itself as VICTIM_ID too (impersonation), and disposes VICTIM_ID's announcement each time;
//  * answers every candidate sent to VICTIM_ID at once, as VICTIM_ID, with cost 1e-6 (a forged report
//    that would be the study's best by far if it counted).
// KEYSTORE '-': no DDS-Security; VICTIM_ID '-': no victim (only the greedy part). SIGTERM ends it early. Prints one line of counts at the end:
//   forged F; own candidates C; most held at once after the first lease expired H
// "Held" counts a candidate from its arrival until its lease_s is over (when the optimizer takes it back),
// less 0.3 s of slack for the two clocks; it is what a slot count buys the worker.
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <csignal>
#include <chrono>
#include <cstdlib>
#include <iostream>
#include <mutex>
#include <thread>
#include <vector>

#include "cpgmatch/dds/convert.hpp"
#include "cpgmatch/dds/participant.hpp"
#include "cpgmatch/dds/security.hpp"

using namespace std::chrono_literals;
namespace transport = cpgmatch::dds;
namespace msg = cpgmatch::msg;

namespace {
volatile std::sig_atomic_t g_stop = 0;
void on_signal(int) { g_stop = 1; }
}  // namespace

int main(int argc, char** argv) {
  if (argc != 8) {
    std::cerr << "usage: rogue_worker DOMAIN KEYSTORE|- ENCLAVE OWN_ID SLOTS VICTIM_ID SECONDS\n";
    return 2;
  }
  const int domain = std::atoi(argv[1]);
  const std::string keystore = argv[2], enclave = argv[3], own = argv[4], victim = argv[6];
  const auto slots = static_cast<std::uint32_t>(std::atoi(argv[5]));
  const double seconds = std::atof(argv[7]);
  if (keystore != "-") transport::select_security({keystore, enclave});
  transport::ParticipantConfig config;
  config.domain = domain;
  config.name = "rogue-worker";
  config.localhost_only = true;
  transport::Participant p(config);
  transport::Writer<msg::RolloutReport> reports(p);
  transport::Writer<msg::WorkerAnnouncement> workers(p);
  std::mutex mutex;
  std::atomic<int> forged{0};
  using Clock = std::chrono::steady_clock;
  struct Held {
    Clock::time_point from, until;
  };
  std::vector<Held> held;
  std::vector<std::pair<std::uint32_t, std::uint32_t>> seen;  // (trial, attempt) of own candidates
  int most_held_after_expiry = 0;
  Clock::time_point first_expiry = Clock::time_point::max();
  transport::Reader<msg::Candidate> candidates(p, [&](const msg::Candidate& c) {
    const std::string to = c.worker_id().to_string();
    if (to == victim && victim != "-") {
      msg::RolloutReport r;
      r.store_id(c.store_id());
      r.study_id(c.study_id());
      r.trial_id(c.trial_id());
      r.attempt(c.attempt());
      r.worker_id(victim);
      r.worker_kind(msg::WORKER_SIM);
      r.ok(true);
      r.cost(1e-6);
      r.j_distance(1e-6);
      r.distance_m(1.0);
      reports.write(r);
      ++forged;
    } else if (to == own) {
      std::lock_guard<std::mutex> lock(mutex);
      const auto key = std::make_pair(c.trial_id(), c.attempt());
      if (std::find(seen.begin(), seen.end(), key) != seen.end()) return;  // delivered twice
      seen.push_back(key);
      const auto now = Clock::now();
      const auto lease = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(c.lease_s() - 0.3));
      held.push_back({now, now + lease});
      first_expiry = std::min(first_expiry, now + lease);
      if (now >= first_expiry) {
        const int n = static_cast<int>(std::count_if(held.begin(), held.end(), [&](const Held& h) { return h.until > now; }));
        most_held_after_expiry = std::max(most_held_after_expiry, n);
      }
    }
  });
  auto announce = [&](const std::string& id, std::uint32_t n) {
    msg::WorkerAnnouncement w;
    w.worker_id(id);
    w.worker_key(transport::worker_key(id));
    w.kind(msg::WORKER_SIM);
    w.host("rogue");
    w.pid(static_cast<std::uint32_t>(getpid()));
    w.slots(n);
    w.accepting(true);
    w.heartbeat_period_s(0.5);
    workers.write(w);
    return w;
  };
  const auto end = Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(seconds));
  std::signal(SIGTERM, on_signal);
  std::signal(SIGINT, on_signal);
  while (Clock::now() < end && !g_stop) {
    announce(own, slots);
    // ...and disposes the victim's announcement (unregister: autodispose), which would drop the victim.
    if (victim != "-") workers.unregister(announce(victim, 64));
    std::this_thread::sleep_for(500ms);
  }
  std::lock_guard<std::mutex> lock(mutex);
  std::cout << "forged " << forged.load() << "; own candidates " << seen.size()
            << "; most held at once after the first lease expired " << most_held_after_expiry << std::endl;
  return 0;
}
