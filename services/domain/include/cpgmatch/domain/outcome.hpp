// How an attempt at a trial ended, as the optimizer sees it. The science's RolloutOutcome (rollout.hpp) says
// how a rollout that ran ended; a worker adds the endings of one that never ran (refused, error).
#pragma once

#include <optional>
#include <string>

#include "cpgmatch/rollout.hpp"

namespace cpgmatch::domain {

enum class Outcome {
  kCompleted,   // ran to the end: a measurement
  kFell,        // fell: a measurement (the fall cost), the model learns where falls are
  kRefused,     // the worker did not start it (a latched stop, a spec it cannot compute, a robot it is not)
  kPlantFault,  // the body failed under it (watchdog, bus, a stop mid-rollout)
  kDiverged,    // the simulation's state went non-finite or physically absurd
  kError,       // anything else that kept it from running (a crashed rollout process, a timeout)
};

const char* to_string(Outcome outcome);  // completed|fell|refused|plant_fault|diverged|error
std::optional<Outcome> outcome_from_string(const std::string& name);
Outcome outcome_of(RolloutOutcome science);

// The rollout measured the gait (completed or fell): its cost is an observation.
inline bool measured(Outcome o) { return o == Outcome::kCompleted || o == Outcome::kFell; }
// Refused, plant fault, diverged: the rollout did not measure the point; its trial is issued again instead of
// being spent (a bounded number of times for faults).
inline bool reissued_not_spent(Outcome o) {
  return o == Outcome::kRefused || o == Outcome::kPlantFault || o == Outcome::kDiverged;
}

enum class WorkerKind { kSimulation, kHardware };
const char* to_string(WorkerKind kind);  // sim | hardware (the names the store and the CLI have always used)

}  // namespace cpgmatch::domain
