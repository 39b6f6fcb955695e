// A box-bounded search space with named, optionally log-scaled dimensions.
//
// The optimizer works in the unit cube; SearchSpace maps points between the user's units and [0, 1]^d.
// Spaces come from YAML:
//
//   parameters:
//     - {name: hip_offset, low: -0.3, high: 0.3, unit: rad}
//     - {name: learning_rate, low: 1e-4, high: 1e-1, log: true}
//   fixed:                      # optional, passed through to the objective unchanged
//     frequency: 1.0
#pragma once

#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace cpgmatch {
class YamlReader;
}

namespace cpgmatch::bo {

struct Dimension {
  std::string name;
  double low = 0.0;
  double high = 1.0;
  bool log_scale = false;
  std::string unit;
};

class SearchSpace {
 public:
  SearchSpace() = default;
  // Throws InputError for empty spaces, duplicate names, low >= high, non-finite or non-positive log bounds.
  explicit SearchSpace(std::vector<Dimension> dims, std::map<std::string, double> fixed = {});

  int size() const { return static_cast<int>(dims_.size()); }
  const std::vector<Dimension>& dimensions() const { return dims_; }
  const std::map<std::string, double>& fixed() const { return fixed_; }
  int index_of(const std::string& name) const;  // -1 when absent

  Eigen::VectorXd to_unit(const Eigen::VectorXd& x) const;
  Eigen::VectorXd from_unit(const Eigen::VectorXd& u) const;

  // Throws InputError when the point has the wrong dimension, a NaN/inf, or a value out of bounds.
  void check_point(const Eigen::VectorXd& x) const;

  // name -> value for a point, including the fixed values.
  std::map<std::string, double> to_named(const Eigen::VectorXd& x) const;
  // Builds a point from names; throws InputError on unknown or missing names.
  Eigen::VectorXd from_named(const std::map<std::string, double>& named) const;

  static SearchSpace load(const std::string& path);
  static SearchSpace from_yaml_text(const std::string& text, const std::string& source_name);
  // Reads `parameters` and `fixed` from a mapping that may hold other keys too (a study file).
  static SearchSpace from_reader(const YamlReader& reader);
  // The paper's six CPG parameters, with frequency 1 Hz and knee amplitude 30 degrees fixed.
  static SearchSpace paper_cpg_space();

 private:
  std::vector<Dimension> dims_;
  std::map<std::string, double> fixed_;
};

}  // namespace cpgmatch::bo
