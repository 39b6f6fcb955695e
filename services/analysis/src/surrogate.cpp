#include "cpgmatch/analysis/surrogate.hpp"

#include <algorithm>
#include <cmath>
#include <random>

#include <Eigen/Core>
#include <fmt/format.h>

#include "cpgmatch/bo/gaussian_process.hpp"

namespace cpgmatch::analysis {

namespace {

double to_unit(const SearchDimension& d, double v) {
  if (d.log_scale) return (std::log(v) - std::log(d.low)) / (std::log(d.high) - std::log(d.low));
  return d.high > d.low ? (v - d.low) / (d.high - d.low) : 0.5;
}

double from_unit(const SearchDimension& d, double u) {
  if (d.log_scale) return std::exp(std::log(d.low) + u * (std::log(d.high) - std::log(d.low)));
  return d.low + u * (d.high - d.low);
}

// Outcomes of a failed rollout that say nothing about its point: the optimizer never modelled them
// (dds::reissued_not_spent; this library has no DDS).
bool says_nothing_about_its_point(const Trial& t) {
  return !t.ok && (t.outcome == "refused" || t.outcome == "plant_fault" || t.outcome == "diverged");
}

struct Data {
  Eigen::MatrixXd X;  // unit cube, rows are rollouts
  Eigen::VectorXd cost;
};

// The optimizer's data set: every rollout that ran at its cost, a plain failure at the worst cost seen.
Data model_data(const StudyTrials& s, const std::vector<SearchDimension>& dims) {
  double worst = -INFINITY;
  for (const auto& t : s.trials) {
    if (t.ok && std::isfinite(t.cost)) worst = std::max(worst, t.cost);
  }
  std::vector<const Trial*> used;
  for (const auto& t : s.trials) {
    if ((t.ok && std::isfinite(t.cost)) || (!t.ok && std::isfinite(worst) && !says_nothing_about_its_point(t))) {
      used.push_back(&t);
    }
  }
  Data d;
  d.X.resize(static_cast<Eigen::Index>(used.size()), static_cast<Eigen::Index>(dims.size()));
  d.cost.resize(static_cast<Eigen::Index>(used.size()));
  for (std::size_t i = 0; i < used.size(); ++i) {
    for (std::size_t j = 0; j < dims.size(); ++j) {
      const auto it = used[i]->params.find(dims[j].name);
      d.X(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j)) =
          to_unit(dims[j], it == used[i]->params.end() ? dims[j].low : it->second);
    }
    d.cost[static_cast<Eigen::Index>(i)] = used[i]->ok ? used[i]->cost : worst;
  }
  return d;
}

}  // namespace

std::vector<SearchDimension> search_dimensions(const StudyTrials& s) {
  if (!s.dimensions.empty()) return s.dimensions;
  std::vector<SearchDimension> dims;
  for (const auto& [name, b] : s.bounds) dims.push_back({name, b.low, b.high, false, ""});  // older stores: no unit
  return dims;
}

std::optional<SurrogateView> surrogate_view(const StudyTrials& s, std::string* why, int grid_points) {
  const auto fail = [why](std::string reason) {
    if (why) *why = std::move(reason);
    return std::nullopt;
  };
  const std::vector<SearchDimension> dims = search_dimensions(s);
  if (dims.empty()) return fail("the study has no search space");
  const Data data = model_data(s, dims);
  const int n = static_cast<int>(data.cost.size()), d = static_cast<int>(dims.size());
  if (n < 3) return fail(fmt::format("{} rollout(s) ran: a model needs at least 3", n));

  // The optimizer's cost units; a cost <= 0 has no log (a study that allowed it did not model log cost).
  const bool log_cost = s.log_cost && data.cost.minCoeff() > 0.0;
  const Eigen::VectorXd y = log_cost ? Eigen::VectorXd(data.cost.array().log()) : data.cost;
  const bool saved = s.log_cost == log_cost && static_cast<int>(s.model_hyperparameters.size()) == d + 2;

  bo::GaussianProcess gp;
  std::mt19937_64 rng(s.seed);
  SurrogateView view;
  view.rollouts = n;
  if (saved) {
    const Eigen::VectorXd theta =
        Eigen::Map<const Eigen::VectorXd>(s.model_hyperparameters.data(), static_cast<Eigen::Index>(d + 2));
    const bo::GpHyperparameters h = bo::GpHyperparameters::unpack(theta);
    gp.fit(data.X, y, /*optimise=*/false, rng, &h);
    view.source = fmt::format("the optimizer's model: its saved hyperparameters (fit on {} rollouts), {} rollouts, {}",
                              s.model_observations, n, log_cost ? "log cost" : "cost");
  } else {
    gp.fit(data.X, y, /*optimise=*/true, rng);
    view.source = fmt::format("a GP fitted here to {} rollouts ({}; the store saved no model of this study)", n,
                              log_cost ? "log cost" : "cost");
  }

  const Eigen::VectorXd log_l = gp.hyperparameters().log_length_scales;
  double total = 0.0;
  for (int j = 0; j < d; ++j) total += std::exp(-log_l[j]);
  for (int j = 0; j < d; ++j) {
    view.importance.push_back({dims[static_cast<std::size_t>(j)].name, std::exp(log_l[j]), std::exp(-log_l[j]) / total});
  }

  // Partial dependence: every rollout's point with parameter j replaced by the grid value, mean prediction.
  Eigen::MatrixXd C(d, n);
  Eigen::VectorXd mean, sd;
  for (int j = 0; j < d; ++j) {
    const SearchDimension& dim = dims[static_cast<std::size_t>(j)];
    PartialDependence pd;
    pd.name = dim.name;
    for (int g = 0; g < grid_points; ++g) {
      const double u = grid_points > 1 ? static_cast<double>(g) / (grid_points - 1) : 0.5;
      C = data.X.transpose();
      C.row(j).setConstant(u);
      gp.predict_many(C, &mean, &sd);
      const double m = mean.mean();
      pd.x.push_back(from_unit(dim, u));
      pd.cost.push_back(log_cost ? std::exp(m) : m);
    }
    view.partial_dependence.push_back(std::move(pd));
  }
  return view;
}

}  // namespace cpgmatch::analysis
