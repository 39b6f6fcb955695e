#include "optimization_loop.hpp"

#include <future>
#include <vector>

namespace cpgmatch::cli {

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
      Trial trial{done, points[i], running[i].get()};
      if (trial.outcome.ok) optimizer.tell(trial.x, trial.outcome.cost);
      else optimizer.tell_failure(trial.x);
      ++done;
      on_trial(trial);
    }
  }
}

}  // namespace cpgmatch::cli
