#include "cpgmatch/analysis/statistics.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>

namespace cpgmatch::analysis {

double mean(const std::vector<double>& v) {
  if (v.empty()) return std::nan("");
  return std::accumulate(v.begin(), v.end(), 0.0) / static_cast<double>(v.size());
}

double median(std::vector<double> v) {
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

double sample_sd(const std::vector<double>& v) {
  if (v.size() < 2) return std::nan("");
  const double m = mean(v);
  double ss = 0.0;
  for (double x : v) ss += (x - m) * (x - m);
  return std::sqrt(ss / static_cast<double>(v.size() - 1));
}

std::vector<double> average_ranks(const std::vector<double>& v) {
  std::vector<std::size_t> order(v.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return v[a] < v[b]; });
  std::vector<double> ranks(v.size());
  for (std::size_t i = 0; i < order.size();) {
    std::size_t j = i;
    while (j + 1 < order.size() && v[order[j + 1]] == v[order[i]]) ++j;
    const double rank = 0.5 * static_cast<double>(i + j) + 1.0;  // mean of the 1-based ranks i+1..j+1
    for (std::size_t k = i; k <= j; ++k) ranks[order[k]] = rank;
    i = j + 1;
  }
  return ranks;
}

double pearson(const std::vector<double>& x, const std::vector<double>& y) {
  if (x.size() != y.size()) throw std::invalid_argument("pearson: series of different lengths");
  if (x.size() < 2) return std::nan("");
  const double mx = mean(x), my = mean(y);
  double sxy = 0.0, sxx = 0.0, syy = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    sxy += (x[i] - mx) * (y[i] - my);
    sxx += (x[i] - mx) * (x[i] - mx);
    syy += (y[i] - my) * (y[i] - my);
  }
  if (sxx <= 0.0 || syy <= 0.0) return std::nan("");
  return sxy / std::sqrt(sxx * syy);
}

double spearman(const std::vector<double>& x, const std::vector<double>& y) {
  if (x.size() != y.size()) throw std::invalid_argument("spearman: series of different lengths");
  if (x.size() < 3) return std::nan("");
  return pearson(average_ranks(x), average_ranks(y));
}

LineFit least_squares(const std::vector<double>& x, const std::vector<double>& y) {
  if (x.size() != y.size()) throw std::invalid_argument("least_squares: series of different lengths");
  if (x.empty()) return {std::nan(""), std::nan("")};
  const double mx = mean(x), my = mean(y);
  double sxy = 0.0, sxx = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    sxy += (x[i] - mx) * (y[i] - my);
    sxx += (x[i] - mx) * (x[i] - mx);
  }
  const double slope = sxx > 0.0 ? sxy / sxx : 0.0;
  return {my - slope * mx, slope};
}

std::vector<double> residuals(const std::vector<double>& x, const std::vector<double>& y) {
  const LineFit fit = least_squares(x, y);
  std::vector<double> r(x.size());
  for (std::size_t i = 0; i < x.size(); ++i) r[i] = y[i] - (fit.intercept + fit.slope * x[i]);
  return r;
}

double partial_spearman(const std::vector<double>& x, const std::vector<double>& y, const std::vector<double>& z) {
  const double xy = spearman(x, y), xz = spearman(x, z), yz = spearman(y, z);
  const double denominator = std::sqrt((1.0 - xz * xz) * (1.0 - yz * yz));
  if (!(denominator > 0.0)) return std::nan("");
  return (xy - xz * yz) / denominator;
}

SignTest sign_test(const std::vector<double>& values, double reference) {
  SignTest t;
  for (double v : values) {
    if (!std::isfinite(v)) continue;
    t.above += v > reference;
    t.below += v < reference;
  }
  const int n = t.above + t.below;
  const int fewer = std::min(t.above, t.below);
  // P(X <= fewer) for X ~ Binomial(n, 1/2), summed term by term: C(n, k) / 2^n.
  double term = std::pow(0.5, n), tail = 0.0;
  for (int k = 0; k <= fewer; ++k) {
    tail += term;
    term *= static_cast<double>(n - k) / (k + 1);
  }
  t.p_two_sided = std::min(1.0, 2.0 * tail);
  return t;
}

}  // namespace cpgmatch::analysis
