// A worker's heartbeat: who it is, what it offers, and whether it takes work now.
#pragma once

#include <cstdint>
#include <string>

#include "cpgmatch/domain/outcome.hpp"

namespace cpgmatch::domain {

struct WorkerAnnouncement {
  std::uint64_t worker_key = 0;  // worker_key(worker_id)
  std::string worker_id;
  WorkerKind kind = WorkerKind::kSimulation;
  std::string host;
  std::uint32_t pid = 0;
  int slots = 0;                 // concurrent rollouts it accepts
  int busy = 0;                  // rollouts running now
  std::uint64_t completed = 0;   // rollouts reported since it started
  bool accepting = true;         // false while draining or under a latched emergency stop
  double heartbeat_period_s = 0.0;
  std::string status;            // why it is not accepting, in words
  int objective_version = 0;     // the objective version it computes (study_spec.hpp); 0: unknown
};

}  // namespace cpgmatch::domain
