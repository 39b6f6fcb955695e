#include "optimization_loop.hpp"

#include <future>
#include <vector>

#include <fmt/format.h>

namespace cpgmatch::cli {

nlohmann::json named_point_json(const bo::SearchSpace& space, const Eigen::VectorXd& x) {
  nlohmann::json point = nlohmann::json::object();
  for (const auto& [name, value] : space.to_named(x)) point[name] = value;
  return point;
}

Evaluator command_evaluator(const bo::SearchSpace& space, std::string command, double timeout_s) {
  return [&space, command = std::move(command), timeout_s](const Eigen::VectorXd& x) {
    return run_command_objective(command, named_point_json(space, x).dump(), timeout_s);
  };
}

namespace {

// With a log cost transform the model fits log(cost), and tell() refuses a cost <= 0 as bad input, which
// ended `optimize` halfway with exit 2 as if the user's flags were wrong. Such a cost is the objective's
// doing: it counts as a failed evaluation (tell_failure), with the cost in its message.
EvaluationOutcome as_the_model_takes_it(const bo::BayesianOptimizer& optimizer, EvaluationOutcome outcome) {
  if (outcome.ok && optimizer.options().cost_transform == bo::CostTransform::kLog && !(outcome.cost > 0.0)) {
    outcome.ok = false;
    outcome.message = fmt::format("cost {} is not > 0, which --cost-transform log needs; counted as failed", outcome.cost);
  }
  return outcome;
}

}  // namespace

void run_optimization(bo::BayesianOptimizer& optimizer, int budget, int parallel, const Evaluator& evaluate,
                      const TrialCallback& on_trial) {
  int done = 0;
  while (done < budget) {
    const int n = std::min(parallel, budget - done);
    const auto points = optimizer.ask(n);
    std::vector<std::future<EvaluationOutcome>> running;
    running.reserve(points.size());
    for (const auto& x : points) running.push_back(std::async(std::launch::async, evaluate, x));
    for (std::size_t i = 0; i < points.size(); ++i) {
      Trial trial{done, points[i], as_the_model_takes_it(optimizer, running[i].get())};
      if (trial.outcome.ok) optimizer.tell(trial.x, trial.outcome.cost);
      else optimizer.tell_failure(trial.x);
      ++done;
      on_trial(trial);
    }
  }
}

}  // namespace cpgmatch::cli
