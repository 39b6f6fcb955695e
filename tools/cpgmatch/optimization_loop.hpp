// Drives a BayesianOptimizer against an objective that runs in parallel: ask(B), evaluate the B points
// concurrently, tell the results in proposal order. Telling in a fixed order keeps a run deterministic
// for a given seed even though evaluations finish in any order.
#pragma once

#include <functional>
#include <string>

#include <nlohmann/json.hpp>

#include "cpgmatch/command_objective.hpp"
#include "cpgmatch/bo/optimizer.hpp"

namespace cpgmatch::cli {

struct Trial {
  int index = 0;
  Eigen::VectorXd x;
  EvaluationOutcome outcome;
};

using Evaluator = std::function<EvaluationOutcome(const Eigen::VectorXd&)>;
using TrialCallback = std::function<void(const Trial&)>;

// The point as a JSON object {"name": value, ...}, fixed parameters included.
nlohmann::json named_point_json(const bo::SearchSpace& space, const Eigen::VectorXd& x);

// Evaluates a point by running `command` with the point's JSON on stdin (see command_objective.hpp).
// Keeps a reference to `space`, which must outlive the evaluator.
Evaluator command_evaluator(const bo::SearchSpace& space, std::string command, double timeout_s);

// Runs `budget` evaluations, at most `parallel` at a time. Failed evaluations go to tell_failure(), and so
// does a cost <= 0 under a log cost transform (the trial's outcome then says so).
void run_optimization(bo::BayesianOptimizer& optimizer, int budget, int parallel, const Evaluator& evaluate,
                      const TrialCallback& on_trial);

}  // namespace cpgmatch::cli
