#include "cpgmatch/analysis/jitter.hpp"

#include <algorithm>
#include <random>

#include "cpgmatch/analysis/statistics.hpp"
#include "cpgmatch/seeds.hpp"

namespace cpgmatch::analysis {

std::vector<std::map<std::string, double>> jittered_points(const std::map<std::string, double>& params,
                                                           const std::map<std::string, Bounds>& bounds,
                                                           const JitterOptions& options) {
  std::mt19937_64 rng(options.jitter_seed);
  std::uniform_real_distribution<double> factor(1.0 - options.relative, 1.0 + options.relative);
  std::vector<std::map<std::string, double>> points;
  for (int i = 0; i < options.draws; ++i) {
    std::map<std::string, double> p = params;
    // Iterating `bounds` (a sorted map) fixes the order of draws, so a seed always means the same points.
    for (const auto& [name, range] : bounds) {
      auto it = p.find(name);
      if (it == p.end()) continue;
      it->second = std::clamp(it->second * factor(rng), range.low, range.high);
    }
    points.push_back(std::move(p));
  }
  return points;
}

JitterSummary jitter_best(const std::map<std::string, double>& params, const std::map<std::string, Bounds>& bounds,
                          const RolloutEvaluator& evaluate, const JitterOptions& options) {
  JitterSummary s;
  s.relative = options.relative;
  for (const auto& point : jittered_points(params, bounds, options)) {
    // Each draw its own rollout seed, as each trial of a study has: the answer must survive sensor noise
    // (and rough ground) it was not optimised on, not only a 1% change of its parameters.
    const RolloutOutcome o = evaluate(point, derived_seed(options.rollout_seed, 1000000 + s.draws));
    ++s.draws;
    if (!o.ok) {
      ++s.failed;
      continue;
    }
    if (o.fell) ++s.falls;
    s.costs.push_back(o.cost);
  }
  s.cost_mean = mean(s.costs);
  s.cost_sd = sample_sd(s.costs);
  return s;
}

}  // namespace cpgmatch::analysis
