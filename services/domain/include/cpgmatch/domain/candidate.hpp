// A candidate: the optimizer asks one worker to run one rollout of one trial, under the study's spec.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>

#include "cpgmatch/domain/rollout_report.hpp"

namespace cpgmatch::domain {

// The conditions of a rollout: the same for every candidate of a study, except the seed (one per trial).
struct RolloutConditions {
  double entrain_s = 0.0;  // entrainment, not scored, seconds
  double eval_s = 0.0;     // the scored evaluation window, seconds
  std::string terrain;     // flat | step:H@D | rough:A | shift:H@T
  std::uint64_t seed = 0;  // contact-sensor noise and rough-ground seed
};

struct Candidate {
  AttemptId id;
  std::string worker_id;       // the worker it is assigned to
  double lease_s = 0.0;        // its report must arrive within this, or it is issued again
  std::uint64_t spec_key = 0;  // the study's spec (study_spec.hpp) by the first 64 bits of its SHA-256
  RolloutConditions rollout;
  std::map<std::string, double> parameters;  // the complete CPG parameter set, SI units (rad, Hz, fractions)
};

// The complete CPG parameter set a candidate carries, or a reason: unknown names, NaN, values outside a
// parameter's valid range. (A repeated name can only happen on the wire: idl/transport refuses it there.)
std::optional<std::string> check_parameters(const std::map<std::string, double>& parameters);

}  // namespace cpgmatch::domain
