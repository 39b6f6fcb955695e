#include "cpgmatch/bo/search_space.hpp"

#include <algorithm>
#include <cmath>
#include <set>

#include <fmt/format.h>

#include "cpgmatch/errors.hpp"
#include "cpgmatch/yaml_reader.hpp"

namespace cpgmatch::bo {

SearchSpace::SearchSpace(std::vector<Dimension> dims, std::map<std::string, double> fixed)
    : dims_(std::move(dims)), fixed_(std::move(fixed)) {
  if (dims_.empty()) throw InputError("search space: no parameters to optimise");
  std::set<std::string> seen;
  for (const auto& d : dims_) {
    if (d.name.empty()) throw InputError("search space: a parameter has an empty name");
    if (!seen.insert(d.name).second) throw InputError(fmt::format("search space: parameter '{}' appears twice", d.name));
    if (!std::isfinite(d.low) || !std::isfinite(d.high)) {
      throw InputError(fmt::format("search space: parameter '{}' has a non-finite bound", d.name));
    }
    if (!(d.low < d.high)) {
      throw InputError(fmt::format("search space: parameter '{}' needs low < high, got low={} high={}", d.name, d.low, d.high));
    }
    if (d.log_scale && d.low <= 0.0) {
      throw InputError(fmt::format("search space: parameter '{}' is log-scaled and needs low > 0, got {}", d.name, d.low));
    }
    if (fixed_.count(d.name)) {
      throw InputError(fmt::format("search space: parameter '{}' is both optimised and fixed", d.name));
    }
  }
}

int SearchSpace::index_of(const std::string& name) const {
  for (int i = 0; i < size(); ++i) {
    if (dims_[i].name == name) return i;
  }
  return -1;
}

Eigen::VectorXd SearchSpace::to_unit(const Eigen::VectorXd& x) const {
  Eigen::VectorXd u(size());
  for (int i = 0; i < size(); ++i) {
    const auto& d = dims_[i];
    u[i] = d.log_scale ? (std::log(x[i]) - std::log(d.low)) / (std::log(d.high) - std::log(d.low))
                       : (x[i] - d.low) / (d.high - d.low);
  }
  return u;
}

Eigen::VectorXd SearchSpace::from_unit(const Eigen::VectorXd& u) const {
  Eigen::VectorXd x(size());
  for (int i = 0; i < size(); ++i) {
    const auto& d = dims_[i];
    const double t = std::clamp(u[i], 0.0, 1.0);
    x[i] = d.log_scale ? std::exp(std::log(d.low) + t * (std::log(d.high) - std::log(d.low)))
                       : d.low + t * (d.high - d.low);
    x[i] = std::clamp(x[i], d.low, d.high);  // exp/log round-off must not leave the box
  }
  return x;
}

void SearchSpace::check_point(const Eigen::VectorXd& x) const {
  if (x.size() != size()) {
    throw InputError(fmt::format("point has {} values, the search space has {} parameters", x.size(), size()));
  }
  for (int i = 0; i < size(); ++i) {
    const auto& d = dims_[i];
    if (!std::isfinite(x[i])) throw InputError(fmt::format("parameter '{}' is not a finite number", d.name));
    if (x[i] < d.low || x[i] > d.high) {
      throw InputError(fmt::format("parameter '{}' = {} is outside [{}, {}]", d.name, x[i], d.low, d.high));
    }
  }
}

std::map<std::string, double> SearchSpace::to_named(const Eigen::VectorXd& x) const {
  std::map<std::string, double> out = fixed_;
  for (int i = 0; i < size(); ++i) out[dims_[i].name] = x[i];
  return out;
}

Eigen::VectorXd SearchSpace::from_named(const std::map<std::string, double>& named) const {
  Eigen::VectorXd x(size());
  for (int i = 0; i < size(); ++i) {
    const auto it = named.find(dims_[i].name);
    if (it == named.end()) throw InputError(fmt::format("point is missing parameter '{}'", dims_[i].name));
    x[i] = it->second;
  }
  for (const auto& [name, value] : named) {
    if (index_of(name) < 0 && !fixed_.count(name)) throw InputError(fmt::format("unknown parameter '{}'", name));
    (void)value;
  }
  check_point(x);
  return x;
}

namespace {

SearchSpace parse_space(const YamlReader& r, bool only_space_keys) {
  if (only_space_keys) r.reject_unknown_keys({"parameters", "fixed"});
  if (!r.has("parameters")) r.fail("parameters", "is missing");
  const YAML::Node list = r.node()["parameters"];
  if (!list.IsSequence() || list.size() == 0) r.fail("parameters", "must be a non-empty list of {name, low, high}");
  std::vector<Dimension> dims;
  for (std::size_t i = 0; i < list.size(); ++i) {
    const YamlReader item(list[i], r.source(), fmt::format("parameters[{}]", i));
    if (!list[i].IsMap()) item.fail("", "must be a mapping {name, low, high}");
    item.reject_unknown_keys({"name", "low", "high", "log", "unit"});
    Dimension d;
    d.name = item.require_string("name");
    d.low = item.require_double("low");
    d.high = item.require_double("high");
    d.log_scale = item.get_bool("log", false);
    d.unit = item.get_string("unit", "");
    if (!(d.low < d.high)) item.fail("low", fmt::format("must be below high ({} >= {})", d.low, d.high));
    if (d.log_scale && d.low <= 0.0) item.fail("low", "must be > 0 for a log-scaled parameter");
    dims.push_back(d);
  }
  std::map<std::string, double> fixed;
  if (r.has("fixed")) {
    r.child("fixed").for_each_number([&](const std::string& key, double v, const std::string&) { fixed[key] = v; });
  }
  try {
    return SearchSpace(std::move(dims), std::move(fixed));
  } catch (const InputError& e) {
    throw InputError(fmt::format("{}: {}", r.source(), e.what()));
  }
}

}  // namespace

SearchSpace SearchSpace::load(const std::string& path) { return parse_space(YamlReader::from_file(path), true); }

SearchSpace SearchSpace::from_reader(const YamlReader& reader) { return parse_space(reader, false); }

SearchSpace SearchSpace::from_yaml_text(const std::string& text, const std::string& source_name) {
  return parse_space(YamlReader::from_string(text, source_name), true);
}

SearchSpace SearchSpace::paper_cpg_space() {
  // Ranges: the plausible region of each parameter for Morti (see configs/spaces/paper.yaml).
  return SearchSpace({{"hip_offset", -0.35, 0.35, false, "rad"},
                      {"hip_amplitude", 0.1, 0.65, false, "rad"},
                      {"duty_factor_front", 0.3, 0.75, false, "1"},
                      {"duty_factor_hind", 0.3, 0.75, false, "1"},
                      {"knee_phase_shift", 0.0, 0.5, false, "1"},
                      {"overswing", 0.0, 0.5, false, "1"}},
                     {{"frequency", 1.0}, {"knee_amplitude", 0.5236}});
}

}  // namespace cpgmatch::bo
