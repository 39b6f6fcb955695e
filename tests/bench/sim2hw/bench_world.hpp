// The two worlds of the sim-to-hardware benchmark and the rollouts in them.
//
//   "simulation": configs/model/morti.yaml, the model every study optimises on;
//   "hardware":   a reality-gap model (configs/model/<scenario>.yaml) simulated by ODE, exactly what the
//                 CAN emulator runs, with noise seeds of its own (never a simulated trial's seed).
//
// Both are resolved as studies are (study::StudySpec: the model, the rollout settings and the base
// parameters from configs/), so a rollout here computes what a worker computes for the same spec.
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "cpgmatch/bo/optimizer.hpp"
#include "cpgmatch/rollout.hpp"
#include "cpgmatch/sim/sim_rollout.hpp"
#include "cpgmatch/study/study_spec.hpp"

namespace cpgmatch::bench {

// A study spec on `model_path` from the study file text `study_yaml` (study defaults for every key it
// does not name).
study::StudySpec spec_on(const std::string& model_path, const std::string& study_yaml);

// The rollout job of the point x (the spec's search-space units) on the spec's model: what a worker runs.
sim::SimRolloutJob job_for(const study::StudySpec& spec, const Eigen::VectorXd& x, std::uint64_t seed);

// One rollout of the point x (the spec's search-space units) on the spec's model, seeded as given.
RolloutResult rollout(const study::StudySpec& spec, const Eigen::VectorXd& x, std::uint64_t seed,
                      const TraceSink& trace = {});

// A rollout's result as the service turns a worker's report into an observation.
bo::Observation observation_of(const Eigen::VectorXd& x, const RolloutResult& result);

// A simulated study run to its budget the way the service runs it with one simulation worker: ask one
// point, run trial k with the study's trial seed, tell its report, repeat (asynchronous model, one slot).
// The observations in the order the optimizer was told them; the answer is the optimizer's recommendation.
struct SimulatedStudy {
  std::vector<bo::Observation> observations;
  Eigen::VectorXd answer;
  double answer_predicted = 0.0;  // the GP's posterior mean at the answer, cost units
  double wall_s = 0.0;
};
SimulatedStudy run_simulated_study(const study::StudySpec& spec);

// The same, kept in `cache_dir` as <the spec's SHA-256>.json: a second run of the benchmark on the same
// grid, or a larger grid after a small one, reuses the studies it already has.
SimulatedStudy cached_simulated_study(const study::StudySpec& spec, const std::filesystem::path& cache_dir);

// The robot of a scenario: rollouts on the scenario's model, the k-th with derived_seed(stream, k).
class Robot {
 public:
  Robot(const study::StudySpec& hardware, std::uint64_t stream) : spec_(hardware), stream_(stream) {}
  // Runs the next rollout (counted), recording its trace into `trace` when given.
  bo::Observation run(const Eigen::VectorXd& x, const TraceSink& trace = {});
  int rollouts() const { return rollouts_; }
  int falls() const { return falls_; }
  const std::vector<bo::Observation>& log() const { return log_; }
  const study::StudySpec& spec() const { return spec_; }
  std::uint64_t last_seed() const { return last_seed_; }

 private:
  const study::StudySpec& spec_;
  std::uint64_t stream_;
  int rollouts_ = 0, falls_ = 0;
  std::uint64_t last_seed_ = 0;
  std::vector<bo::Observation> log_;
};

// The hardware cost of an answer: its mean over `seeds` fresh noise seeds on the hardware model (never
// counted in a strategy's budget). The same seeds for every point, so strategies are compared on the same
// noise; each point is evaluated once however often it is asked for (thread-safe).
struct Evaluation {
  std::vector<double> costs;
  int falls = 0;
  double mean() const;
};
class AnswerEvaluator {
 public:
  AnswerEvaluator(study::StudySpec hardware, int seeds) : spec_(std::move(hardware)), seeds_(seeds) {}
  Evaluation evaluate(const Eigen::VectorXd& x);

 private:
  const study::StudySpec spec_;  // its own copy: the evaluator outlives where it was made
  int seeds_;
  std::mutex mutex_;
  std::map<std::vector<double>, Evaluation> done_;
};

nlohmann::json to_json(const Evaluation& e);
nlohmann::json named_json(const bo::SearchSpace& space, const Eigen::VectorXd& x);

}  // namespace cpgmatch::bench
