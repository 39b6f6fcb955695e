#include "cpgmatch/service/enqueued_gaits.hpp"

#include <cmath>

#include <fmt/format.h>

#include "cpgmatch/errors.hpp"
#include "cpgmatch/params.hpp"

namespace cpgmatch::service {

Eigen::VectorXd point_of_gait(const study::StudySpec& spec, const domain::EnqueuedGait& gait) {
  const bo::SearchSpace& space = spec.config().space;
  const std::string from = gait.source.empty() ? std::string("enqueued gait") : gait.source;
  std::map<std::string, double> study_values = to_map(spec.base_parameters());
  for (const auto& [name, value] : space.fixed()) study_values[name] = value;
  Eigen::VectorXd x(space.size());
  for (int i = 0; i < space.size(); ++i) {
    const std::string& name = space.dimensions()[static_cast<std::size_t>(i)].name;
    const auto it = gait.parameters.find(name);
    if (it == gait.parameters.end()) {
      throw InputError(fmt::format("{}: no value for '{}', which the study searches", from, name));
    }
    x[i] = it->second;
  }
  for (const auto& [name, value] : gait.parameters) {
    if (space.index_of(name) >= 0) continue;
    const auto own = study_values.find(name);
    if (own == study_values.end()) throw InputError(fmt::format("{}: '{}' is not a CPG parameter", from, name));
    // A parameter file gives every parameter; only a searched one may differ from the study's value.
    if (std::abs(value - own->second) > 1e-9 * std::max(1.0, std::abs(own->second))) {
      throw InputError(fmt::format("{}: {} = {} is not the study's value {} (the study does not search it, so every "
                                   "trial runs {})",
                                   from, name, value, own->second, own->second));
    }
  }
  try {
    space.check_point(x);
  } catch (const InputError& e) {
    throw InputError(fmt::format("{}: outside the study's search space: {}", from, e.what()));
  }
  if (const auto& constraints = spec.config().optimizer.constraints) {
    if (const auto violated = constraints->violated(x)) {
      throw InputError(fmt::format("{}: violates the study's constraint \"{}\"", from, *violated));
    }
  }
  return x;
}

study::StudySpec with_budget(const study::StudySpec& spec, int budget) {
  nlohmann::json tree = spec.tree();
  // A double, as every number of the study's section (budget 150 and 150.0 are one study).
  tree["study"]["budget"] = static_cast<double>(budget);
  return study::StudySpec::from_json_text(tree.dump(), "extended spec");
}

}  // namespace cpgmatch::service
