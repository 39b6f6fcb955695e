// The five ways the benchmark spends a robot's rollouts (issue 23), each with the optimizer code and the
// study defaults the service uses (bo::BayesianOptimizer, bo::HardwareOptimizer driven as the coordinator's
// HardwareModelJob drives it, the calibration library as `cpgmatch calibrate` uses it).
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "bench_world.hpp"

namespace cpgmatch::bench {

// What one strategy did on the robot: its answer, the answer it would have given after each of its
// hardware rollouts (for the cost-against-rollouts curve), and the rollouts themselves.
struct StrategyRun {
  Eigen::VectorXd answer;
  std::vector<Eigen::VectorXd> answer_after;  // [k]: the answer after hardware rollout k+1
  std::vector<bo::Observation> hardware;      // the robot's rollouts, in order
  std::vector<double> proposal_fall_probability;  // the model's predicted fall probability, per proposal
  nlohmann::json details = nlohmann::json::object();
};

// (1) The simulated optimum transferred: the simulated study's answer, run once on the robot.
StrategyRun transferred_optimum(const SimulatedStudy& simulation, Robot& robot);

// (2) Hardware-only BO: a study with explore_on: hardware and the budget (`hardware_study` resolved from
// such a file: its optimizer settings are the study's), every rollout on the robot.
StrategyRun hardware_only(const study::StudySpec& hardware_study, Robot& robot);

// (3), (4): one model over both sources (`hardware: {strategy: transfer | multi_fidelity, budget: N}` in
// `study`). The simulated study's results are told in the order the service tells them; the robot runs
// `budget` proposals. How far the simulation runs ahead: before hardware proposal j (0-based), the model
// has been told min(all, start_after + j * simulated_per_hardware) simulated results (a robot rollout of
// 20 s plus its reset takes about as long as that many simulated rollouts on the study's workers).
// `already` are hardware results the study has before its first proposal (calibration's rollouts).
StrategyRun model_over_both(const study::StudySpec& study, const std::vector<bo::Observation>& simulated, Robot& robot,
                            int simulated_per_hardware, const std::vector<bo::Observation>& already = {});

// (5) Calibrate, then transfer: `calibration_rollouts` robot rollouts of the simulated optimum with their
// traces; the model values the scenario changes are fitted from morti.yaml to the traces' first
// `window_s` seconds (they count in the budget); a simulated study on the calibrated model (written to
// `calibrated_model_file`, cached in `cache_dir`); then `transfer` with the rest of the budget, the
// calibration rollouts among its hardware results.
struct CalibrateThenTransfer {
  const study::StudySpec* simulation = nullptr;   // morti.yaml with the study's keys (no hardware key)
  std::string simulation_model_path;
  std::string study_yaml;                          // the study's keys, without `hardware`
  int hardware_budget = 15;
  int calibration_rollouts = 2;
  double window_s = 3.0;
  int grid_points = 8;
  int simulated_per_hardware = 30;
  std::filesystem::path calibrated_model_file;
  std::filesystem::path cache_dir;
};
StrategyRun calibrate_then_transfer(const CalibrateThenTransfer& setup, const SimulatedStudy& simulation,
                                    Robot& robot);

}  // namespace cpgmatch::bench
