// What a worker reports for one attempt at a trial: which attempt, who ran it, how it ended, and what it
// measured. A plain value type: the wire form (msg::RolloutReport) is made from it in idl/transport, the
// store's JSON by report_json.hpp.
#pragma once

#include <cmath>
#include <cstdint>
#include <optional>
#include <string>

#include "cpgmatch/cost.hpp"
#include "cpgmatch/domain/outcome.hpp"
#include "cpgmatch/energy.hpp"
#include "cpgmatch/rollout.hpp"

namespace cpgmatch::domain {

// One attempt at one trial of one study of one store. Study and trial ids are unique within a store only;
// store_id 0 means "no store named" (tests, and a report that predates store ids).
struct AttemptId {
  std::uint64_t store_id = 0;
  int study_id = 0;
  int trial_id = 0;
  int attempt = 0;  // 0 first issue, +1 each re-issue
};

// The control loop of a hardware worker over one rollout (zero from simulation workers).
struct LoopTiming {
  double jitter_p50_us = 0.0;  // wake-up lateness after each absolute deadline, microseconds
  double jitter_p99_us = 0.0;
  double jitter_max_us = 0.0;
  int overruns = 0;            // control periods whose work ran past their deadline
};

// What one rollout measured (meaningful only when the outcome measured the gait).
struct RolloutSummary {
  double cost = std::nan("");       // the objective, the fall cost when it fell
  CostTerms terms;                  // J_feedback, J_distance, J_pitch, J_contact, J_periodicity
  FeedbackFractions feedback;       // per mechanism: fraction of time, averaged over legs
  double normalized_torque = std::nan("");  // eq. 1, N m per (m/s)
  double summed_torque_nm = std::nan("");   // eq. 1's numerator: sum over joints of mean |torque|, N m
  double fall_time_s = -1.0;        // -1 when it did not fall
  double distance_m = std::nan("");
  double mean_speed_mps = std::nan("");
  // What the motors spent (energy.hpp): positive work per joint and per metre, Joule loss and electrical
  // energy of the DC-motor model, costs of transport, signed mean torques. NaN: not measured (a report from
  // a release before energy, a plant without a motor model).
  EnergyMeasures energy;
};

struct RolloutReport {
  AttemptId id;
  std::string worker_id;
  WorkerKind worker_kind = WorkerKind::kSimulation;
  Outcome outcome = Outcome::kCompleted;
  std::string error;        // why it did not measure (empty when it did)
  RolloutSummary summary;
  double wall_time_s = 0.0; // the worker's wall time for the rollout, seconds
  LoopTiming loop;
  // No gait was simulated: a service benchmark's synthetic cost (cpgmatch-sim-worker --fake-rollout-ms).
  // Kept in the store and every export, marked; never in a figure or the science report.
  bool synthetic = false;

  bool ok() const { return measured(outcome); }  // it ran (a fall is ok)
  bool fell() const { return outcome == Outcome::kFell; }
};

// The report of a rollout that ran (ids and worker fields left for the caller).
RolloutReport report_of(const RolloutResult& result);

// A reason to refuse a report before it touches a study (a non-finite cost on a measured report, a negative
// time, no worker id), or nothing.
std::optional<std::string> check_report(const RolloutReport& report);

}  // namespace cpgmatch::domain
