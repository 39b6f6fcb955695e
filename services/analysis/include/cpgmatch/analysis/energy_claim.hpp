// The paper's energy claim tested the way it states it, for every measure of what the motors spend.
//
// The paper: matching (less feedback) lowered the normalised torque, eq. 1, over the optimisation, without
// energy in the cost. Eq. 1 is Σ mean |τ| / v; in a series-elastic knee its numerator is mostly the steady
// torque of carrying the body (work-free but not free: it heats the motor), and it divides by speed as
// J_distance does, so a study that only walks faster lowers it. So each measure is tested two ways:
//  - learning: its median over the last rollouts against the initial design's (non-fallen rollouts);
//  - matching: Spearman's rho with J_feedback over non-fallen rollouts, raw and at equal speed. Equal speed
//    twice: the residual of log(measure) on log(speed) (what is left once a power law in speed is removed),
//    and the partial rank correlation given speed (no functional form assumed). A positive rho says: the
//    less feedback, the less the motors spend.
#pragma once

#include <string>
#include <vector>

#include "cpgmatch/analysis/trial.hpp"

namespace cpgmatch::analysis {

struct EnergyMeasureInfo {
  const char* key;    // the JSON key under "measures"
  const char* label;  // for tables and figures, with its unit
  double (*of)(const Trial&);
};
// eq. 1; Σ |signed mean τ| / v; positive work per metre; electrical cost of transport. (The mechanical cost
// of transport is positive work per metre / (m g): the same ranks and ratio, so it is not tested twice.)
const std::vector<EnergyMeasureInfo>& energy_measures();

struct MeasureStats {
  std::string key;
  double initial_median = 0.0, late_median = 0.0, ratio = 0.0;  // learning, non-fallen rollouts
  int samples = 0;                    // non-fallen rollouts with a positive measure and speed
  double rho_feedback = 0.0;          // Spearman with J_feedback
  double rho_feedback_residual = 0.0; // ... with the residual of log(measure) on log(speed)
  double rho_feedback_partial = 0.0;  // partial Spearman given speed
  double speed_exponent = 0.0;        // b of measure ~ speed^b (-1: a pure 1/speed)
};

// `initial_last`: the last rollout (1-based) of the initial design; `late_first`: the first of the late sample.
std::vector<MeasureStats> energy_claim(const StudyTrials& study, int initial_last, int late_first);

// How much of eq. 1's numerator is the knees' steady torque: Σ_knees |signed mean τ| / Σ_joints mean |τ|,
// the median over non-fallen rollouts (NaN without energy data).
double knee_steady_share_median(const StudyTrials& study);

// One sentence for the report on what dominates eq. 1, from that share.
std::string eq1_sentence(double knee_steady_share);

}  // namespace cpgmatch::analysis
