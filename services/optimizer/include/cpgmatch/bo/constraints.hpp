// Parameter constraints: inequalities over named parameters that a study's proposals must satisfy, e.g.
// the robot's hip envelope (configs/robot/morti.yaml: |hip_offset| + hip_amplitude (1 + overswing) <= 1.33 rad):
//
//   constraints:
//     - "hip_offset + hip_amplitude * (1 + overswing) <= 1.33"
//     - "hip_offset - hip_amplitude * (1 + overswing) >= -1.33"
//
// The language is small on purpose: numbers, parameter names, + - * / (unary minus too), parentheses, and
// one comparison, <= or >=, between two such expressions. A constraint is parsed once (a study's submit),
// then evaluated millions of times during an acquisition search, so it is compiled to a little tree over
// value slots rather than re-read.
//
// Names are bound to a search space (ParameterConstraints): a searched dimension takes the point's value,
// any other name (a fixed or base parameter) the constant value it has in the study.
#pragma once

#include <functional>
#include <map>
#include <optional>
#include <utility>
#include <memory>
#include <optional>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "cpgmatch/bo/search_space.hpp"

namespace cpgmatch::bo {

// A constraint that does not parse: what is wrong and where (a 1-based character position in the text).
class ConstraintSyntaxError : public std::runtime_error {
 public:
  ConstraintSyntaxError(const std::string& what, int position)
      : std::runtime_error(what + " at position " + std::to_string(position)), position_(position) {}
  int position() const { return position_; }

 private:
  int position_;
};

class Constraint {
 public:
  // Parses `text`; every name must be in `known_names`. Throws ConstraintSyntaxError.
  static Constraint parse(const std::string& text, const std::set<std::string>& known_names);

  const std::string& text() const { return text_; }
  // The parameter names it uses.
  const std::set<std::string>& names() const { return names_; }
  // How far inside the constraint `values` are (>= 0: satisfied): rhs - lhs for <=, lhs - rhs for >=, in
  // the expression's units. Throws std::out_of_range for a name `values` lacks.
  double slack(const std::map<std::string, double>& values) const;

  // A division whose divisor can be 0 (or is not finite) for some values of the names, each name in its
  // [low, high] from `range_of` (interval arithmetic: conservative, so `a / (b - b)` is refused too); or
  // nothing. Such a constraint is refused at submit: its value would be inf or NaN there, and a NaN
  // silently made the point infeasible. Example: "divides by a term that ranges over [-0.3, 0.3]".
  std::optional<std::string> division_by_zero(
      const std::function<std::pair<double, double>(const std::string&)>& range_of) const;

  // The parsed expression tree (immutable, shared by copies). A name is bound to a dimension index or
  // replaced by its constant value when a ParameterConstraints is made.
  struct Expr {
    enum class Kind { kNumber, kName, kDimension, kNegate, kAdd, kSubtract, kMultiply, kDivide };
    Kind kind = Kind::kNumber;
    double number = 0.0;    // kNumber
    std::string name;       // kName
    int dimension = -1;     // kDimension
    std::shared_ptr<const Expr> a, b;
  };

 private:
  friend class ParameterConstraints;
  std::string text_;
  std::set<std::string> names_;
  std::shared_ptr<const Expr> lhs_, rhs_;
  bool less_equal_ = true;
};

// A study's constraints bound to its search space: what the optimizer asks whether a point may be proposed.
class ParameterConstraints {
 public:
  // `other_values`: a value for every name the constraints use that is not a dimension of `space` (its fixed
  // values and the study's base parameters). Throws InputError naming a name that has no value.
  ParameterConstraints(const std::vector<Constraint>& constraints, const SearchSpace& space,
                       const std::map<std::string, double>& other_values);

  bool empty() const { return bound_.empty(); }
  std::size_t size() const { return bound_.size(); }
  // A point in the space's units / in the unit cube.
  bool feasible(const Eigen::VectorXd& x) const { return !violated(x); }
  bool feasible_unit(const Eigen::VectorXd& u) const { return feasible(space_.from_unit(u)); }
  // The text of the first constraint `x` violates, or nothing.
  std::optional<std::string> violated(const Eigen::VectorXd& x) const;

 private:
  struct Bound {
    std::string text;
    std::shared_ptr<const Constraint::Expr> lhs, rhs;  // names replaced by dimensions or constants
    bool less_equal = true;
  };
  SearchSpace space_;
  std::vector<Bound> bound_;
};

}  // namespace cpgmatch::bo
