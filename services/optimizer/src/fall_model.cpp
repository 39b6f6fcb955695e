#include "cpgmatch/bo/fall_model.hpp"

#include <cmath>
#include <numbers>

namespace cpgmatch::bo {
namespace {

double normal_cdf(double z) { return 0.5 * std::erfc(-z / std::sqrt(2.0)); }
double normal_pdf(double z) { return std::exp(-0.5 * z * z) / std::sqrt(2.0 * std::numbers::pi); }

// A latent std this small means "at an observed point": the sign of the mean decides.
constexpr double kMinStd = 1e-9;

}  // namespace

FallModel::FallModel(GpOptions options) : options_(options), gp_(options) {}

void FallModel::fit(const Eigen::MatrixXd& X, const std::vector<bool>& fell, bool optimise, std::mt19937_64& rng,
                    const GpHyperparameters* start) {
  gp_ = GaussianProcess(options_);
  int falls = 0;
  Eigen::VectorXd labels(static_cast<Eigen::Index>(fell.size()));
  for (std::size_t i = 0; i < fell.size(); ++i) {
    labels[static_cast<Eigen::Index>(i)] = fell[i] ? 1.0 : -1.0;
    falls += fell[i] ? 1 : 0;
  }
  if (falls == 0 || falls == static_cast<int>(fell.size())) return;  // nothing to separate
  gp_.fit(X, labels, optimise, rng, start);
}

double FallModel::probability_safe(const Eigen::VectorXd& u) const {
  if (!active()) return 1.0;
  const Prediction p = gp_.predict(u);
  return normal_cdf(-p.mean / std::max(p.std, kMinStd));
}

SafeProbability FallModel::probability_safe_with_gradient(const Eigen::VectorXd& u) const {
  SafeProbability out;
  out.dp_dx = Eigen::VectorXd::Zero(u.size());
  if (!active()) return out;
  Eigen::VectorXd dmean, dstd;
  const Prediction p = gp_.predict_with_gradient(u, &dmean, &dstd);
  const double s = std::max(p.std, kMinStd);
  const double z = -p.mean / s;
  out.p = normal_cdf(z);
  // dz/dx = -(dmean s - mean dstd) / s^2 (dstd counts only while the std is above the floor).
  const Eigen::VectorXd dz = p.std > kMinStd ? Eigen::VectorXd(-(dmean * s - p.mean * dstd) / (s * s))
                                             : Eigen::VectorXd(-dmean / s);
  out.dp_dx = normal_pdf(z) * dz;
  return out;
}

Eigen::VectorXd FallModel::probability_safe_many(const Eigen::MatrixXd& C) const {
  if (!active()) return Eigen::VectorXd::Ones(C.cols());
  Eigen::VectorXd mean, std;
  gp_.predict_many(C, &mean, &std);
  Eigen::VectorXd out(C.cols());
  for (Eigen::Index j = 0; j < C.cols(); ++j) out[j] = normal_cdf(-mean[j] / std::max(std[j], kMinStd));
  return out;
}

}  // namespace cpgmatch::bo
