// The one way a simulated rollout of a study is set up from its spec: the worker's rollout process and
// `cpgmatch rerun` both call this, so a stored trial re-runs to the same bits.
#pragma once

#include <cstdint>
#include <map>
#include <string>

#include "cpgmatch/sim/sim_rollout.hpp"
#include "cpgmatch/study/study_spec.hpp"

namespace cpgmatch::study {

// The rollout of one trial: the spec's model, settings and base parameters, the trial's parameter values
// (CPG names, SI units) on top, and the candidate's terrain, seed and timing (seconds).
sim::SimRolloutJob sim_job_for(const StudySpec& spec, const std::map<std::string, double>& parameters,
                               const std::string& terrain, std::uint64_t seed, double entrain_s, double eval_s);

// The rollout seed of trial `trial_id` (sensor noise, rough ground): a pure function of the study's seed.
std::uint64_t trial_seed(const StudySpec& spec, int trial_id);

}  // namespace cpgmatch::study
