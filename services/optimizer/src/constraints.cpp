#include "cpgmatch/bo/constraints.hpp"

#include <algorithm>
#include <cctype>
#include <functional>
#include <iterator>
#include <cmath>
#include <cstdlib>

#include <fmt/format.h>

#include "cpgmatch/errors.hpp"

namespace cpgmatch::bo {

namespace {

using Expr = Constraint::Expr;
using ExprPtr = std::shared_ptr<const Expr>;

ExprPtr make(Expr::Kind kind, ExprPtr a = nullptr, ExprPtr b = nullptr) {
  auto e = std::make_shared<Expr>();
  e->kind = kind;
  e->a = std::move(a);
  e->b = std::move(b);
  return e;
}

// Recursive descent over one constraint's text. Positions in errors are 1-based characters.
class Parser {
 public:
  Parser(const std::string& text, const std::set<std::string>& known) : text_(text), known_(known) {}

  // expr (<= | >=) expr, and nothing after it.
  void parse(ExprPtr& lhs, ExprPtr& rhs, bool& less_equal, std::set<std::string>& names) {
    lhs = expression();
    skip_space();
    const std::size_t at = pos_;
    if (match("<=")) {
      less_equal = true;
    } else if (match(">=")) {
      less_equal = false;
    } else if (pos_ < text_.size() && (text_[pos_] == '<' || text_[pos_] == '>' || text_[pos_] == '=')) {
      fail("only <= and >= compare (a strict < or > cannot be told apart from <= for real numbers)", at);
    } else {
      fail(pos_ >= text_.size() ? "expected <= or >= before the end" : "expected an operator, <= or >=", at);
    }
    rhs = expression();
    skip_space();
    if (pos_ < text_.size()) {
      fail(text_[pos_] == '<' || text_[pos_] == '>' ? "one comparison per constraint (write two constraints)"
                                                    : "unexpected text after the comparison",
           pos_);
    }
    names = std::move(names_);
  }

 private:
  [[noreturn]] void fail(const std::string& what, std::size_t at) const {
    throw ConstraintSyntaxError(what, static_cast<int>(at) + 1);
  }
  void skip_space() {
    while (pos_ < text_.size() && std::isspace(static_cast<unsigned char>(text_[pos_]))) ++pos_;
  }
  bool match(const char* token) {
    skip_space();
    const std::string t(token);
    if (text_.compare(pos_, t.size(), t) != 0) return false;
    pos_ += t.size();
    return true;
  }
  // The next character is a single-character operator `c` (and not the start of <= or >=).
  bool match_char(char c) {
    skip_space();
    if (pos_ >= text_.size() || text_[pos_] != c) return false;
    ++pos_;
    return true;
  }

  // One precedence level of left-associative binary operators over operands that `next` parses.
  template <typename Next>
  ExprPtr left_associative(const Next& next, char op1, Expr::Kind kind1, char op2, Expr::Kind kind2) {
    ExprPtr left = next();
    for (;;) {
      if (match_char(op1)) left = make(kind1, left, next());
      else if (match_char(op2)) left = make(kind2, left, next());
      else return left;
    }
  }
  ExprPtr expression() {
    return left_associative([this] { return term(); }, '+', Expr::Kind::kAdd, '-', Expr::Kind::kSubtract);
  }
  ExprPtr term() {
    return left_associative([this] { return unary(); }, '*', Expr::Kind::kMultiply, '/', Expr::Kind::kDivide);
  }
  ExprPtr unary() {
    if (match_char('-')) return make(Expr::Kind::kNegate, unary());
    if (match_char('+')) return unary();
    return primary();
  }
  ExprPtr primary() {
    skip_space();
    if (pos_ >= text_.size()) fail("expected a number, a parameter name or '(' before the end", pos_);
    const std::size_t at = pos_;
    const char c = text_[pos_];
    if (c == '(') {
      ++pos_;
      ExprPtr inner = expression();
      if (!match_char(')')) fail("expected ')'", pos_);
      return inner;
    }
    if (std::isdigit(static_cast<unsigned char>(c)) || c == '.') {
      const char* begin = text_.c_str() + pos_;
      char* end = nullptr;
      const double value = std::strtod(begin, &end);
      if (end == begin || !std::isfinite(value)) fail("not a number", at);
      pos_ += static_cast<std::size_t>(end - begin);
      auto e = std::make_shared<Expr>();
      e->number = value;
      return e;
    }
    if (std::isalpha(static_cast<unsigned char>(c)) || c == '_') {
      while (pos_ < text_.size() && (std::isalnum(static_cast<unsigned char>(text_[pos_])) || text_[pos_] == '_')) ++pos_;
      const std::string name = text_.substr(at, pos_ - at);
      if (known_.count(name) == 0) {
        std::string list;
        for (const auto& k : known_) list += (list.empty() ? "" : ", ") + k;
        fail(fmt::format("unknown parameter '{}' (known: {})", name, list), at);
      }
      names_.insert(name);
      auto e = std::make_shared<Expr>();
      e->kind = Expr::Kind::kName;
      e->name = name;
      return e;
    }
    fail(fmt::format("unexpected '{}': expected a number, a parameter name or '('", c), at);
  }

  const std::string& text_;
  const std::set<std::string>& known_;
  std::set<std::string> names_;
  std::size_t pos_ = 0;
};

// The tree with every name resolved by `resolve` (to a dimension, or to a constant).
template <typename Resolve>
ExprPtr resolved(const ExprPtr& e, const Resolve& resolve) {
  if (!e) return nullptr;
  if (e->kind == Expr::Kind::kName) return resolve(e->name);
  if (!e->a) return e;  // a number: shared as is
  return make(e->kind, resolved(e->a, resolve), resolved(e->b, resolve));
}

// `value_of(e)` gives a leaf's value (a number, a name's value or a dimension's).
template <typename Leaf>
double evaluate(const Expr& e, const Leaf& value_of) {
  switch (e.kind) {
    case Expr::Kind::kNegate: return -evaluate(*e.a, value_of);
    case Expr::Kind::kAdd: return evaluate(*e.a, value_of) + evaluate(*e.b, value_of);
    case Expr::Kind::kSubtract: return evaluate(*e.a, value_of) - evaluate(*e.b, value_of);
    case Expr::Kind::kMultiply: return evaluate(*e.a, value_of) * evaluate(*e.b, value_of);
    case Expr::Kind::kDivide: return evaluate(*e.a, value_of) / evaluate(*e.b, value_of);
    default: return value_of(e);
  }
}

// >= 0: satisfied. NaN (a division by zero, say) is never >= 0: such a point is infeasible.
double slack_of(double lhs, double rhs, bool less_equal) { return less_equal ? rhs - lhs : lhs - rhs; }

}  // namespace

Constraint Constraint::parse(const std::string& text, const std::set<std::string>& known_names) {
  Constraint c;
  c.text_ = text;
  Parser(text, known_names).parse(c.lhs_, c.rhs_, c.less_equal_, c.names_);
  return c;
}

namespace {

struct Interval {
  double lo, hi;
};

// The interval `e` takes with every name in its range; `problem` gets the first divisor that can be 0.
Interval interval_of(const Expr& e, const std::function<std::pair<double, double>(const std::string&)>& range_of,
                     std::optional<std::string>& problem) {
  switch (e.kind) {
    case Expr::Kind::kNumber: return {e.number, e.number};
    case Expr::Kind::kName: {
      const auto [lo, hi] = range_of(e.name);
      return {lo, hi};
    }
    case Expr::Kind::kNegate: {
      const Interval a = interval_of(*e.a, range_of, problem);
      return {-a.hi, -a.lo};
    }
    default: break;
  }
  if (!e.a || !e.b) return {0.0, 0.0};  // a bound dimension: not reached before binding
  const Interval a = interval_of(*e.a, range_of, problem), b = interval_of(*e.b, range_of, problem);
  switch (e.kind) {
    case Expr::Kind::kAdd: return {a.lo + b.lo, a.hi + b.hi};
    case Expr::Kind::kSubtract: return {a.lo - b.hi, a.hi - b.lo};
    case Expr::Kind::kMultiply: {
      const double p[] = {a.lo * b.lo, a.lo * b.hi, a.hi * b.lo, a.hi * b.hi};
      return {*std::min_element(std::begin(p), std::end(p)), *std::max_element(std::begin(p), std::end(p))};
    }
    case Expr::Kind::kDivide: {
      if (!(b.lo > 0.0 || b.hi < 0.0) || !std::isfinite(b.lo) || !std::isfinite(b.hi)) {
        if (!problem) {
          problem = b.lo == b.hi ? fmt::format("divides by a term that is always {:g}", b.lo)
                                 : fmt::format("divides by a term that ranges over [{:g}, {:g}], which holds 0", b.lo, b.hi);
        }
        return {-HUGE_VAL, HUGE_VAL};
      }
      const double p[] = {a.lo / b.lo, a.lo / b.hi, a.hi / b.lo, a.hi / b.hi};
      return {*std::min_element(std::begin(p), std::end(p)), *std::max_element(std::begin(p), std::end(p))};
    }
    default: return {0.0, 0.0};
  }
}

}  // namespace

std::optional<std::string> Constraint::division_by_zero(
    const std::function<std::pair<double, double>(const std::string&)>& range_of) const {
  std::optional<std::string> problem;
  (void)interval_of(*lhs_, range_of, problem);
  (void)interval_of(*rhs_, range_of, problem);
  return problem;
}

double Constraint::slack(const std::map<std::string, double>& values) const {
  auto leaf = [&](const Expr& e) { return e.kind == Expr::Kind::kName ? values.at(e.name) : e.number; };
  return slack_of(evaluate(*lhs_, leaf), evaluate(*rhs_, leaf), less_equal_);
}

ParameterConstraints::ParameterConstraints(const std::vector<Constraint>& constraints, const SearchSpace& space,
                                           const std::map<std::string, double>& other_values)
    : space_(space) {
  for (const Constraint& c : constraints) {
    auto resolve = [&](const std::string& name) -> ExprPtr {
      auto e = std::make_shared<Expr>();
      if (const int d = space.index_of(name); d >= 0) {
        e->kind = Expr::Kind::kDimension;
        e->dimension = d;
      } else if (const auto fixed = space.fixed().find(name); fixed != space.fixed().end()) {
        e->number = fixed->second;
      } else if (const auto other = other_values.find(name); other != other_values.end()) {
        e->number = other->second;
      } else {
        throw InputError(fmt::format("constraint \"{}\": parameter '{}' is neither searched nor has a value", c.text(), name));
      }
      return e;
    };
    bound_.push_back(Bound{c.text(), resolved(c.lhs_, resolve), resolved(c.rhs_, resolve), c.less_equal_});
  }
}

std::optional<std::string> ParameterConstraints::violated(const Eigen::VectorXd& x) const {
  auto leaf = [&](const Expr& e) { return e.kind == Expr::Kind::kDimension ? x[e.dimension] : e.number; };
  for (const Bound& b : bound_) {
    if (!(slack_of(evaluate(*b.lhs, leaf), evaluate(*b.rhs, leaf), b.less_equal) >= 0.0)) return b.text;
  }
  return std::nullopt;
}

}  // namespace cpgmatch::bo
