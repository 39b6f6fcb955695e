// Small statistics used by the science report. NaN in, NaN out: an empty sample gives NaN, never 0,
// so a missing statistic cannot pass for a measured one.
#pragma once

#include <vector>

namespace cpgmatch::analysis {

double mean(const std::vector<double>& v);
double median(std::vector<double> v);
// Sample standard deviation (n - 1); NaN for fewer than two values.
double sample_sd(const std::vector<double>& v);

// 1-based ranks; tied values share the average of the ranks they span (1, 2.5, 2.5, 4).
std::vector<double> average_ranks(const std::vector<double>& v);
double pearson(const std::vector<double>& x, const std::vector<double>& y);
// Spearman's rho with ties: Pearson's r of the average ranks. NaN for < 3 pairs or a constant series.
double spearman(const std::vector<double>& x, const std::vector<double>& y);

struct LineFit {
  double intercept = 0.0;
  double slope = 0.0;
};
// Ordinary least squares y = intercept + slope * x. Slope 0 when x is constant.
LineFit least_squares(const std::vector<double>& x, const std::vector<double>& y);
// y - (intercept + slope * x) for each point of the fit.
std::vector<double> residuals(const std::vector<double>& x, const std::vector<double>& y);

// Spearman's partial correlation of x and y given z: the rank correlations combined as
// (r_xy - r_xz r_yz) / sqrt((1 - r_xz^2) (1 - r_yz^2)). NaN when z ranks exactly like x or y.
double partial_spearman(const std::vector<double>& x, const std::vector<double>& y, const std::vector<double>& z);

// The sign test: how many values lie above and below `reference` (ties dropped), and the two-sided
// binomial p of a split at least that uneven when either side is equally likely.
struct SignTest {
  int above = 0;
  int below = 0;
  double p_two_sided = 1.0;
};
SignTest sign_test(const std::vector<double>& values, double reference);

}  // namespace cpgmatch::analysis
