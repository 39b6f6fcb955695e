#include "cpgmatch/domain/outcome.hpp"

namespace cpgmatch::domain {

const char* to_string(Outcome o) {
  switch (o) {
    case Outcome::kCompleted: return "completed";
    case Outcome::kFell: return "fell";
    case Outcome::kRefused: return "refused";
    case Outcome::kPlantFault: return "plant_fault";
    case Outcome::kDiverged: return "diverged";
    case Outcome::kError: return "error";
  }
  return "unknown";
}

std::optional<Outcome> outcome_from_string(const std::string& name) {
  for (const Outcome o : {Outcome::kCompleted, Outcome::kFell, Outcome::kRefused, Outcome::kPlantFault,
                          Outcome::kDiverged, Outcome::kError}) {
    if (name == to_string(o)) return o;
  }
  return std::nullopt;
}

Outcome outcome_of(RolloutOutcome science) {
  switch (science) {
    case RolloutOutcome::kCompleted: return Outcome::kCompleted;
    case RolloutOutcome::kFell: return Outcome::kFell;
    case RolloutOutcome::kPlantFault: return Outcome::kPlantFault;
    case RolloutOutcome::kDiverged: return Outcome::kDiverged;
  }
  return Outcome::kError;
}

const char* to_string(WorkerKind kind) { return kind == WorkerKind::kHardware ? "hardware" : "sim"; }

}  // namespace cpgmatch::domain
