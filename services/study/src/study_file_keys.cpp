#include "cpgmatch/study/study_file_keys.hpp"

#include <array>
#include <cstring>

namespace cpgmatch::study {
namespace {

// Ranges and defaults here are the parser's (study_config.cpp, study_spec.cpp); a test reads a file of
// every key back to check none is missing (StudyFileKeys.*).
constexpr std::array kKeys{
    StudyFileKey{"name", "text, at most 64 bytes, printable", "",
                 "The study's name (required). Shown by status, watch and the figures."},
    StudyFileKey{"budget", "integer 1..100000", "150",
                 "Rollouts the study counts as observations, the initial design included. A rollout that could not "
                 "measure its point (refused, a plant fault, a diverged simulation, an error) is issued again and "
                 "does not spend the budget."},
    StudyFileKey{"initial_points", "integer 1..budget", "15",
                 "Random (or quasi-random) points evaluated before the Gaussian-process model proposes any."},
    StudyFileKey{"initial_design", "random | lhs | sobol | halton", "random",
                 "How the initial points are drawn: uniform random as the paper, Latin hypercube, or a Sobol or Halton "
                 "sequence."},
    StudyFileKey{"acquisition", "gp_hedge | ei | pi | lcb", "gp_hedge",
                 "The acquisition function; gp_hedge chooses among EI, PI and LCB by their past gains, as "
                 "scikit-optimize's gp_minimize does."},
    StudyFileKey{"liar", "believer | min | mean | max", "believer",
                 "How rollouts still running enter the model when several run at once: believer puts them at the "
                 "model's own mean; min, mean and max are constant liars."},
    StudyFileKey{"cost_transform", "log | none", "log",
                 "What the GP models: log(cost) (a rollout's cost is positive, and falls cost 13 to 19 against 0.4 to 2 "
                 "for walking) or the cost itself."},
    StudyFileKey{"fall_model", "true | false", "false",
                 "Learn where rollouts fall and weight proposals by the probability of not falling (docs/optimizer.md)."},
    StudyFileKey{"seed", "integer 0..2000000000", "0",
                 "Seeds the initial design, the acquisition search and, with lockstep, everything that decides which "
                 "trials a study runs."},
    StudyFileKey{"rollout", "mapping", "", "The rollout's length, in seconds."},
    StudyFileKey{"rollout.entrain_s", "seconds, 0..3600", "10",
                 "Entrainment before the scored window: the CPG and the body settle, nothing is scored."},
    StudyFileKey{"rollout.eval_s", "seconds, 0.01..3600", "10", "The scored evaluation window."},
    StudyFileKey{"terrain", "flat | step:H@D | rough:A | shift:H@T", "flat",
                 "The ground: flat; a step of height H metres at distance D metres; rough ground of amplitude A metres; "
                 "a ground shift of H metres at time T seconds."},
    StudyFileKey{"parameters", "list of {name, low, high}", "the paper's six",
                 "The CPG parameters the study optimises, with their bounds in SI units (rad, Hz, fractions). Names: "
                 "hip_offset, hip_amplitude, knee_amplitude, frequency, duty_factor_front, duty_factor_hind, "
                 "knee_phase_shift, overswing."},
    StudyFileKey{"fixed", "mapping name: value", "frequency 1 Hz, knee_amplitude 0.5236 rad",
                 "CPG parameters held at a value instead of optimised."},
    StudyFileKey{"lease_s", "seconds, 0..86400", "0",
                 "Wall time a rollout may take before its candidate is issued again to another worker; 0 derives it "
                 "from the rollout's length."},
    StudyFileKey{"explore_on", "simulation | hardware", "simulation",
                 "Which workers run the study's exploration. hardware: a hardware-only study on the robot agent."},
    StudyFileKey{"lockstep", "integer 0..1024", "0",
                 "N > 0: reproducible; trial k is proposed from the results of trials 0..k-N-1 in trial order. 0: "
                 "asynchronous, fastest, not reproducible. study run and reproduce use their worker count."},
    StudyFileKey{"robot", "a shipped robot's name, or a robot.yaml (or its folder) relative to the study file", "",
                 "The robot the study is about (docs/your-robot.md): its model, legs, gaits, default preset and search "
                 "space. The spec holds the robot's whole content under its hash. Only the agent of that robot (its "
                 "worker id, or the CN before a '/') runs the study's hardware rollouts; another robot's agent refuses "
                 "them. Without it: Morti from configs/model/morti.yaml, which `model` may override."},
    StudyFileKey{"hardware", "mapping", "",
                 "How the robot is used beside the simulation (docs/optimizer.md). Without it a study is simulation "
                 "only."},
    StudyFileKey{"hardware.strategy", "validate | transfer | multi_fidelity", "",
                 "validate: after the simulated study, sets around its best run on the robot and go to the sim2real "
                 "table, not into the model. transfer: a hardware GP whose prior mean is the simulation's posterior. "
                 "multi_fidelity: one co-kriging model over both sources, hardware = rho * sim + delta. The study's "
                 "answer is then the hardware posterior's best."},
    StudyFileKey{"hardware.budget", "integer 1..1000", "15 (validate: 10)", "Hardware rollouts (validate: sets)."},
    StudyFileKey{"hardware.max_fall_probability", "0..1", "0.2",
                 "transfer and multi_fidelity: a hardware proposal whose predicted fall probability is above this is "
                 "not sent while a safer one exists."},
    StudyFileKey{"hardware.safe_margin", "0..10", "0.1",
                 "transfer and multi_fidelity: after the first robot rollout (the simulation's best), a proposal's "
                 "pessimistic cost (mean + safe_beta std on the hardware model) must be at most (1 + safe_margin) "
                 "times the best robot cost so far; when no candidate under the fall limit is, the one with the "
                 "lowest bound runs and the log and the trial record say so. 0.1: the 10% a study's answer is judged by."},
    StudyFileKey{"hardware.safe_beta", "0..10", "2",
                 "transfer and multi_fidelity: standard deviations in the pessimistic cost of safe_margin (2: a "
                 "one-sided 97.7% bound)."},
    StudyFileKey{"hardware.start_after", "integer, initial_points..budget", "budget",
                 "Simulated results the study holds before its first hardware proposal, whose point is the best of "
                 "them (budget: the whole simulated exploration; a spec stored before this default, without the "
                 "key, keeps initial_points)."},
    StudyFileKey{"hardware.spread", "0..1", "0.10", "validate: the relative spread of the sets around the best."},
    StudyFileKey{"validation", "mapping {hardware_sets, spread}", "",
                 "The older spelling of hardware: {strategy: validate, budget, spread}."},
    StudyFileKey{"constraints", "list of at most 64 inequalities", "",
                 "Parameter constraints, each an inequality over the CPG parameters (numbers, parameter names, + - * /, "
                 "parentheses, one <= or >=), e.g. \"hip_offset + hip_amplitude * (1 + overswing) <= 1.33\". Fixed "
                 "and base parameters take their study values. The initial design and the acquisition search never "
                 "propose a point that breaks one; they are part of the spec's hash (docs/steering.md)."},
    StudyFileKey{"enqueue", "list of at most 64 parameter files", "",
                 "Known gaits to run first (parameter files like configs/params/default.yaml, relative to the study "
                 "file), as Optuna's enqueue_trial: they count in the budget and the model learns from them. "
                 "cpgmatch study enqueue ID --params F.yaml queues more into an open or stopped study."},
    StudyFileKey{"model", "mapping, or a model file's path", "configs/model/morti.yaml",
                 "Overrides of single values of the robot model (e.g. {knee_spring: {stiffness_nm_per_rad: 20}}), or a "
                 "whole model file (e.g. one cpgmatch calibrate wrote), relative to the study file: the submitting "
                 "client sends its content. The study's spec holds the whole resolved model."},
    StudyFileKey{"rollout_settings", "mapping", "configs/rollout.yaml",
                 "Overrides of the controller, feedback, contact sensing and cost settings (e.g. {cost: {weights: "
                 "{feedback: 4}}})."},
    StudyFileKey{"base_parameters", "mapping", "configs/params/default.yaml",
                 "Overrides of the CPG parameters the study neither optimises nor fixes."},
};

}  // namespace

std::span<const StudyFileKey> study_file_keys() { return kKeys; }

std::vector<std::string> top_level_study_file_keys() {
  std::vector<std::string> keys;
  for (const StudyFileKey& k : kKeys) {
    if (std::strchr(k.key, '.') == nullptr) keys.emplace_back(k.key);
  }
  return keys;
}

}  // namespace cpgmatch::study
