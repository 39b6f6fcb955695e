// A study: which parameters to optimise, the budget and the rollout conditions. Every key but `name`
// defaults to the paper's value (150 rollouts, 15 random, gp_hedge, six parameters, 10 s + 10 s).
//
//   name: my-study
//   budget: 150
//   initial_points: 15
//   acquisition: gp_hedge
//   seed: 0
//   rollout: {entrain_s: 10, eval_s: 10}
//   terrain: flat
//   parameters: [{name: hip_offset, low: -0.35, high: 0.35}, ...]   # the paper's six when omitted
//   fixed: {frequency: 1.0, knee_amplitude: 0.5236}
//   lease_s: 120            # wall seconds a worker may take per rollout before it is re-issued
//   explore_on: simulation  # worker kind running the exploration (budget): simulation | hardware
//   validation: {hardware_sets: 10, spread: 0.10}   # optional: the hardware validation phase
//   hardware: {strategy: multi_fidelity, budget: 15, max_fall_probability: 0.2, safe_margin: 0.1}   # optional: see HardwareConfig
//   robot: odrive-quadruped # optional: the study's robot (robot_file.hpp); only its agent runs hardware rollouts
//   constraints: ["hip_offset + hip_amplitude * (1 + overswing) <= 1.33"]   # optional, see bo/constraints.hpp
//   enqueue: [good-gait.yaml]   # optional: parameter files run first (docs/steering.md)
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "cpgmatch/bo/constraints.hpp"
#include "cpgmatch/bo/optimizer.hpp"
#include "cpgmatch/bo/search_space.hpp"

namespace cpgmatch::study {

// The paper's protocol after the exploration: N parameter sets around the study's answer, each parameter
// varied by at most +-spread of its value (relative), run on hardware workers. Only with a `validation`
// key: a study without one ends with its exploration (no hardware worker is ever waited for).
struct ValidationConfig {
  bool enabled = false;
  int hardware_sets = 10;
  double spread = 0.10;
};

enum class WorkerKindWanted { kSimulation, kHardware };

// How a study uses the robot (`hardware:` key):
//  * validate: the paper's protocol, the ValidationConfig phase above (`hardware: {strategy: validate, budget: N,
//    spread: S}` is `validation: {hardware_sets: N, spread: S}`, which stays as its older spelling);
//  * transfer / multi_fidelity: one model over both sources (bo::HardwareOptimizer). The exploration (`budget`)
//    runs on simulation workers as before; every simulated result also goes to the hardware model, and once
//    `start_after` simulated results are in, each free slot of the study's robot gets a hardware proposal
//    until `budget` hardware rollouts are spent. The study's answer is the hardware posterior's best.
enum class HardwareStrategy { kNone, kValidate, kTransfer, kMultiFidelity };
std::string to_string(HardwareStrategy s);

struct HardwareConfig {
  HardwareStrategy strategy = HardwareStrategy::kNone;  // kNone: the study file has no `hardware` key
  int budget = 15;  // hardware rollouts (transfer, multi_fidelity); validate: ValidationConfig::hardware_sets
  // A hardware proposal whose predicted fall probability exceeds this is not sent while a safer one exists.
  double max_fall_probability = 0.2;
  // Simulated results told to the model before the first hardware proposal. A study file without the key
  // gets its budget, written into its spec at resolve (study_spec.cpp says why); a stored spec without it
  // (resolved before that default) reads as the study's initial_points, the default it ran with.
  int start_after = 0;
  // Safe exploration (bo::HardwareOptimizerOptions::safe_margin, safe_beta, where the defaults are argued):
  // a proposal's cost bound mean + safe_beta std must be within (1 + safe_margin) of the best robot cost.
  double safe_margin = 0.1;
  double safe_beta = 2.0;
  // One model over both sources: hardware proposals and a hardware answer.
  bool models_hardware() const {
    return strategy == HardwareStrategy::kTransfer || strategy == HardwareStrategy::kMultiFidelity;
  }
};

struct StudyConfig {
  std::string name = "paper-study";
  int budget = 150;
  bo::OptimizerOptions optimizer;
  bo::SearchSpace space = bo::SearchSpace::paper_cpg_space();
  double entrain_s = 10.0;
  double eval_s = 10.0;
  std::string terrain = "flat";
  // Wall seconds a rollout may take before its candidate is re-issued; <= 0: derived from the rollout length.
  double lease_s = 0.0;
  WorkerKindWanted explore_on = WorkerKindWanted::kSimulation;
  // The study's robot (robot_file.hpp): in a spec, its description's name. Only its agent may run the study's
  // hardware rollouts: its worker id (or the CN before a '/'). Empty: Morti's model, any robot agent. Another
  // robot's agent refuses the candidates (it never measures on the wrong body).
  std::string robot;
  ValidationConfig validation;
  HardwareConfig hardware;
  // Reproducible parallelism: with lockstep N > 0, trial k is proposed from exactly the results of trials
  // 0..k-N-1, told in trial order one at a time, with trials k-N..k-1 pending. At most N rollouts then run
  // at once and the study is a function of its seed and N alone, whatever order the reports arrive in.
  // 0: asynchronous (reports told as they arrive, every free slot filled at once; not reproducible).
  int lockstep = 0;
  bool lockstep_given = false;  // the file says lockstep (study run sets it to its worker count otherwise)
  // Inequalities over CPG parameter names every proposal satisfies (bo/constraints.hpp). Parsed here (an
  // unknown name or a syntax error names the file's line and the position); bound to the space and the
  // base parameters by StudySpec (bind_constraints), which sets optimizer.constraints.
  std::vector<bo::Constraint> constraints;
  // Parameter files whose gaits run first (`enqueue:`), as the file names them. The submitting client reads
  // them (relative to the study file) and sends their values with the submit; the names stay out of the spec.
  std::vector<std::string> enqueue_files;
  // Some of its work only a robot can run (a validation phase, a hardware exploration, hardware proposals).
  bool needs_hardware() const {
    return validation.enabled || explore_on == WorkerKindWanted::kHardware || hardware.models_hardware();
  }
  double effective_lease_s() const { return lease_s > 0.0 ? lease_s : 60.0 + 3.0 * (entrain_s + eval_s); }
};

// The largest study file a service takes (bytes), checked before anything parses it. A study with every
// model, settings and parameter value written out (`study show`) is about 10 kB; this leaves room for
// comments and long parameter lists, not for a file built to exhaust the service's memory.
inline constexpr std::size_t kMaxStudyFileBytes = 256 * 1024;

// Binds `config.constraints` to its space, with `base_parameters` (every CPG parameter's value in the
// study) for the names it does not search or fix: sets config.optimizer.constraints.
void bind_constraints(StudyConfig& config, const std::map<std::string, double>& base_parameters);

// Throws InputError naming the file, line and field.
StudyConfig load_study_config(const std::string& path);
// The same for a study file's text (a submitted study); `source_name` stands in for the file name.
// `default_space`: the space of a study that names no `parameters` (its robot's); null: the paper's.
StudyConfig load_study_config_text(const std::string& text, const std::string& source_name,
                                   const bo::SearchSpace* default_space = nullptr);

}  // namespace cpgmatch::study
