#include "cpgmatch/bo/test_functions.hpp"

#include <cmath>
#include <numbers>

#include <fmt/format.h>

#include "cpgmatch/errors.hpp"

namespace cpgmatch::bo {
namespace {

constexpr double kPi = std::numbers::pi;

SearchSpace box(int d, double low, double high) {
  std::vector<Dimension> dims;
  for (int i = 0; i < d; ++i) dims.push_back({fmt::format("x{}", i + 1), low, high, false, ""});
  return SearchSpace(dims);
}

double branin(const Eigen::VectorXd& x) {
  const double b = 5.1 / (4.0 * kPi * kPi), c = 5.0 / kPi, t = 1.0 / (8.0 * kPi);
  const double u = x[1] - b * x[0] * x[0] + c * x[0] - 6.0;
  return u * u + 10.0 * (1.0 - t) * std::cos(x[0]) + 10.0;
}

double hartmann(const Eigen::VectorXd& x, const double* alpha, const double* A, const double* P, int d) {
  double sum = 0.0;
  for (int i = 0; i < 4; ++i) {
    double inner = 0.0;
    for (int j = 0; j < d; ++j) {
      const double diff = x[j] - P[i * d + j];
      inner += A[i * d + j] * diff * diff;
    }
    sum += alpha[i] * std::exp(-inner);
  }
  return -sum;
}

const double kHartmannAlpha[4] = {1.0, 1.2, 3.0, 3.2};
const double kH3A[12] = {3.0, 10, 30, 0.1, 10, 35, 3.0, 10, 30, 0.1, 10, 35};
const double kH3P[12] = {0.3689, 0.1170, 0.2673, 0.4699, 0.4387, 0.7470,
                         0.1091, 0.8732, 0.5547, 0.0381, 0.5743, 0.8828};
const double kH6A[24] = {10, 3, 17, 3.5, 1.7, 8, 0.05, 10, 17, 0.1, 8, 14,
                         3, 3.5, 1.7, 10, 17, 8, 17, 8, 0.05, 10, 0.1, 14};
const double kH6P[24] = {0.1312, 0.1696, 0.5569, 0.0124, 0.8283, 0.5886, 0.2329, 0.4135,
                         0.8307, 0.3736, 0.1004, 0.9991, 0.2348, 0.1451, 0.3522, 0.2883,
                         0.3047, 0.6650, 0.4047, 0.8828, 0.8732, 0.5743, 0.1091, 0.0381};

double ackley(const Eigen::VectorXd& x) {
  const double n = static_cast<double>(x.size());
  const double s1 = x.squaredNorm() / n;
  const double s2 = (2.0 * kPi * x.array()).cos().sum() / n;
  return -20.0 * std::exp(-0.2 * std::sqrt(s1)) - std::exp(s2) + 20.0 + std::numbers::e;
}

double rosenbrock(const Eigen::VectorXd& x) {
  double s = 0.0;
  for (int i = 0; i + 1 < x.size(); ++i) s += 100.0 * std::pow(x[i + 1] - x[i] * x[i], 2) + std::pow(1.0 - x[i], 2);
  return s;
}

double levy(const Eigen::VectorXd& x) {
  const int d = static_cast<int>(x.size());
  auto w = [&](int i) { return 1.0 + (x[i] - 1.0) / 4.0; };
  double s = std::pow(std::sin(kPi * w(0)), 2);
  for (int i = 0; i < d - 1; ++i) s += std::pow(w(i) - 1.0, 2) * (1.0 + 10.0 * std::pow(std::sin(kPi * w(i) + 1.0), 2));
  s += std::pow(w(d - 1) - 1.0, 2) * (1.0 + std::pow(std::sin(2.0 * kPi * w(d - 1)), 2));
  return s;
}

double styblinski_tang(const Eigen::VectorXd& x) {
  return 0.5 * (x.array().pow(4) - 16.0 * x.array().square() + 5.0 * x.array()).sum();
}

}  // namespace

std::vector<std::string> test_function_names() {
  return {"branin", "hartmann3", "hartmann6", "ackley", "rosenbrock", "levy", "styblinski-tang", "quadratic1d",
          "ackley20", "levy20"};
}

TestFunction test_function(const std::string& name) {
  if (name == "branin") {
    return {name, SearchSpace({{"x1", -5.0, 10.0, false, ""}, {"x2", 0.0, 15.0, false, ""}}), 0.397887357729738, branin};
  }
  if (name == "hartmann3") {
    return {name, box(3, 0.0, 1.0), -3.86278214782076,
            [](const Eigen::VectorXd& x) { return hartmann(x, kHartmannAlpha, kH3A, kH3P, 3); }};
  }
  if (name == "hartmann6") {
    return {name, box(6, 0.0, 1.0), -3.32236801141551,
            [](const Eigen::VectorXd& x) { return hartmann(x, kHartmannAlpha, kH6A, kH6P, 6); }};
  }
  if (name == "ackley") return {name, box(2, -32.768, 32.768), 0.0, ackley};
  if (name == "rosenbrock") return {name, box(2, -5.0, 10.0), 0.0, rosenbrock};
  if (name == "levy") return {name, box(2, -10.0, 10.0), 0.0, levy};
  // 20-dimensional versions for large studies (issue 36). Ackley on [-5, 10]^20, the box of the TuRBO paper
  // (Eriksson et al. 2019) and BoTorch's examples: its standard box (+-32.8) is almost flat noise at 20-D for
  // any budget a GP can take, so regret would say nothing about the optimizer.
  if (name == "ackley20") return {name, box(20, -5.0, 10.0), 0.0, ackley};
  if (name == "levy20") return {name, box(20, -10.0, 10.0), 0.0, levy};
  if (name == "styblinski-tang") return {name, box(2, -5.0, 5.0), -39.16616570377142 * 2.0, styblinski_tang};
  if (name == "quadratic1d") {
    return {name, SearchSpace({{"x", -2.0, 3.0, false, ""}}), 0.0,
            [](const Eigen::VectorXd& x) { return (x[0] - 0.7) * (x[0] - 0.7); }};
  }
  std::string names;
  for (const auto& n : test_function_names()) names += (names.empty() ? "" : ", ") + n;
  throw InputError(fmt::format("unknown test function '{}' (known: {})", name, names));
}

}  // namespace cpgmatch::bo
