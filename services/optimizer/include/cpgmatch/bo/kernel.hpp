// Covariance kernels as policies (the pattern of limbo): a kernel is a type that maps scaled distances to
// covariances, written once, and every GP computation that needs a covariance or its derivative goes
// through it (the Gram matrix and its likelihood gradient, a cross-covariance, a prediction's gradient).
// A faster or different kernel is then one type, not three hand-written copies of the same formula.
//
// A stationary kernel here is k(x, x') = amplitude * K::value(r), r^2 = sum_j (x_j - x'_j)^2 / l_j^2. It
// provides, for an Eigen array of distances r >= 0 (any shape, evaluated element-wise):
//   value(r)  the correlation at r (1 at r = 0), as an expression;
//   slope(r)  -(1/r) d value/dr, the factor that every derivative shares:
//               dk/dlog l_j = amplitude * slope * (x_j - x'_j)^2 / l_j^2
//               dk/dx_j     = -amplitude * slope * (x_j - x'_j) / l_j^2
//   value_and_slope(r, value, slope)  both at once, sharing the exponential.
#pragma once

#include <cmath>

#include <Eigen/Core>

namespace cpgmatch::bo {

// Matern 5/2: (1 + sqrt5 r + 5/3 r^2) exp(-sqrt5 r); slope 5/3 (1 + sqrt5 r) exp(-sqrt5 r). Twice
// differentiable, scikit-optimize's choice for BO (smooth enough for L-BFGS, rough enough for real costs).
struct Matern52 {
  static constexpr double kSqrt5 = 2.23606797749978969640917366873128;

  // Each factor once: value = value_factor * decay, slope = slope_factor * decay. value_and_slope()
  // shares decay between the two (the exponential is most of the kernel's cost).
  template <typename Derived>
  static auto decay(const Eigen::ArrayBase<Derived>& r) {
    // Whole-array expressions, so that exp runs vectorised (Eigen's SIMD exp, within an ulp or two of libm's).
    return (-kSqrt5 * r).exp();
  }
  template <typename Derived>
  static auto value_factor(const Eigen::ArrayBase<Derived>& r) {
    return 1.0 + kSqrt5 * r + (5.0 / 3.0) * r.square();
  }
  template <typename Derived>
  static auto slope_factor(const Eigen::ArrayBase<Derived>& r) {
    return (5.0 / 3.0) * (1.0 + kSqrt5 * r);
  }

  template <typename Derived>
  static auto value(const Eigen::ArrayBase<Derived>& r) {
    return value_factor(r) * decay(r);
  }
  template <typename Derived>
  static auto slope(const Eigen::ArrayBase<Derived>& r) {
    return slope_factor(r) * decay(r);
  }
  template <typename Derived, typename Value, typename Slope>
  static void value_and_slope(const Eigen::ArrayBase<Derived>& r, Value& value, Slope& slope) {
    slope = decay(r);  // the shared exponential, then each factor in place
    value = value_factor(r) * slope;
    slope = slope_factor(r) * slope;
  }
};

// The kernel of every GP in this library (the cost GP, the fall classifier, both parts of the
// multi-fidelity model).
using Kernel = Matern52;

}  // namespace cpgmatch::bo
