#include "cpgmatch/analysis/fall_locations.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include "cpgmatch/analysis/statistics.hpp"

namespace cpgmatch::analysis {
namespace {

int params_at_bound(const std::vector<double>& u, double margin) {
  const auto at_bound = [&](double x) { return x <= margin || x >= 1.0 - margin; };
  return static_cast<int>(std::count_if(u.begin(), u.end(), at_bound));
}

double distance(const std::vector<double>& a, const std::vector<double>& b) {
  double s = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) s += (a[i] - b[i]) * (a[i] - b[i]);
  return std::sqrt(s);
}

}  // namespace

FallLocations fall_locations(const StudyTrials& study, const FallLocationOptions& options) {
  FallLocations out;
  std::vector<double> fall_bounds, walked_bounds, fall_distances, walked_distances;
  const Trial* best = nullptr;  // the lowest-cost rollout that ran, so far
  std::vector<double> best_u;   // ... and its unit-cube point
  for (const Trial& t : study.trials) {
    if (!t.ok) continue;
    const std::vector<double> u = unit_point(t, study.bounds);
    if (t.trial_id >= study.initial_points && best != nullptr) {
      const double at_bound = params_at_bound(u, options.bound_margin);
      const double d = distance(u, best_u);
      if (t.fell) {
        ++out.falls;
        fall_bounds.push_back(at_bound);
        fall_distances.push_back(d);
        if (d <= options.near_best) ++out.falls_near_best;
      } else {
        ++out.walked;
        walked_bounds.push_back(at_bound);
        walked_distances.push_back(d);
      }
    }
    // The best so far as the report sees it: a rollout without a finite cost is never the best.
    if (std::isfinite(t.cost) && (best == nullptr || t.cost < best->cost)) {
      best = &t;
      best_u = u;
    }
  }
  out.falls_params_at_bound_median = median(fall_bounds);
  out.walked_params_at_bound_median = median(walked_bounds);
  out.falls_distance_to_best_median = median(fall_distances);
  out.walked_distance_to_best_median = median(walked_distances);
  return out;
}

}  // namespace cpgmatch::analysis
