#include "cpgmatch/analysis/recommendation.hpp"

#include <cmath>
#include <random>
#include <vector>

#include <Eigen/Core>

#include "cpgmatch/bo/gaussian_process.hpp"

namespace cpgmatch::analysis {

std::optional<Recommendation> recommend(const StudyTrials& study) {
  std::vector<const Trial*> ran;
  for (const auto& t : study.trials) {
    if (t.ok && std::isfinite(t.cost)) ran.push_back(&t);
  }
  if (ran.size() < 2 || study.bounds.empty()) return std::nullopt;

  // Rows in the unit cube of the optimised parameters (the GP's expected input), in bounds order.
  const int n = static_cast<int>(ran.size()), d = static_cast<int>(study.bounds.size());
  Eigen::MatrixXd X(n, d);
  Eigen::VectorXd y(n);
  for (int i = 0; i < n; ++i) {
    const std::vector<double> u = unit_point(*ran[i], study.bounds);
    for (int j = 0; j < d; ++j) X(i, j) = u[static_cast<std::size_t>(j)];
    y[i] = ran[i]->cost;
  }
  bo::GaussianProcess gp;
  std::mt19937_64 rng(study.seed);
  gp.fit(X, y, /*optimise=*/true, rng);

  Recommendation best;
  double best_mean = INFINITY;
  for (int i = 0; i < n; ++i) {
    const bo::Prediction p = gp.predict(X.row(i).transpose());
    if (p.mean < best_mean) {
      best_mean = p.mean;
      best.rollout = ran[i]->trial_id + 1;
      best.predicted_cost = p.mean;
      best.predicted_sd = p.std;
      best.observed_cost = ran[i]->cost;
      best.fell = ran[i]->fell;
      best.params = ran[i]->params;
    }
  }
  return best;
}

}  // namespace cpgmatch::analysis
