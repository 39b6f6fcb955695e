// What the optimizer publishes about a study: its state, each evaluated trial, and its spec.
#pragma once

#include <cmath>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "cpgmatch/domain/rollout_report.hpp"
#include "cpgmatch/domain/study_status.hpp"

namespace cpgmatch::domain {

// The study's answer: the counted trial with the lowest GP posterior mean (the lowest cost before the model is
// fitted). With noisy rollouts the best single cost is biased low; this is what to run.
struct Recommendation {
  int trial = 0;
  double predicted_cost = std::nan("");
  std::map<std::string, double> params;
};

// One searched parameter as the study's search space defines it (the robot's names, bounds and units).
struct SearchAxis {
  std::string name;
  double low = 0.0;
  double high = 1.0;
  bool log_scale = false;
  std::string unit;  // SI ("rad", "Hz"); "1" or empty: dimensionless
};

struct StudyState {
  int study_id = 0;
  std::string name;
  StudyStatus status = StudyStatus::kRunning;
  int budget = 0;       // exploration budget + validation sets
  int completed = 0;    // reports counted (either phase)
  int in_flight = 0;
  int failed = 0;       // evaluations that could not run (counted in completed)
  int falls = 0;
  int reissued = 0;     // candidates issued again after a lost worker, a lease, a refusal or a fault
  int workers = 0;      // live workers serving the optimizer
  double best_cost = std::nan("");  // NaN before the first measured result
  int best_trial = 0;
  std::map<std::string, double> best_params;
  double best_normalized_torque = std::nan("");
  double best_speed_mps = std::nan("");
  double elapsed_s = 0.0;       // since the study was created (wall time, survives restarts)
  double rollouts_per_s = 0.0;  // since this service started serving it
  std::string message;
  bool has_recommendation = false;
  Recommendation recommendation;
  // What a viewer needs to name the study's values: its robot's legs, in the order of every per-leg value its
  // reports carry (Morti's FL FR HL HR, a hexapod's L1 R1 ...), and its search space in its order. Empty from
  // an optimizer built before they were published.
  std::vector<std::string> leg_names;
  std::vector<SearchAxis> search_space;
};

// Every evaluated trial with its result.
struct TrialRecord {
  int study_id = 0;
  int trial_id = 0;
  bool initial = false;  // from the random initial design
  bool enqueued = false;  // a queued known gait (`enqueue`), not a proposal of the model
  std::map<std::string, double> parameters;  // the searched parameters, SI units
  RolloutReport report;
  // The report's legs by name, leg by leg as its per-leg energy lists them (the study's robot's legs).
  std::vector<std::string> leg_names;
};

// An open study's resolved spec as published for workers (study_spec.hpp): the canonical JSON and its hash.
struct SpecPublication {
  std::uint64_t key = 0;  // the first 64 bits of sha256
  int objective_version = 0;
  std::string sha256;     // hex SHA-256 of json
  std::string json;
};

}  // namespace cpgmatch::domain
