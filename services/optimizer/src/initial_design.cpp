#include "cpgmatch/bo/initial_design.hpp"

#include <algorithm>
#include <cmath>
#include <memory>
#include <numeric>
#include <random>
#include <vector>

#include <fmt/format.h>
#include <gsl/gsl_qrng.h>

#include "cpgmatch/errors.hpp"

namespace cpgmatch::bo {

std::string to_string(InitialDesign d) {
  switch (d) {
    case InitialDesign::kRandom: return "random";
    case InitialDesign::kLatinHypercube: return "lhs";
    case InitialDesign::kSobol: return "sobol";
    case InitialDesign::kHalton: return "halton";
  }
  return "?";
}

InitialDesign initial_design_from_string(std::string_view name) {
  if (name == "random") return InitialDesign::kRandom;
  if (name == "lhs") return InitialDesign::kLatinHypercube;
  if (name == "sobol") return InitialDesign::kSobol;
  if (name == "halton") return InitialDesign::kHalton;
  throw InputError(fmt::format("unknown initial design '{}' (known: random, lhs, sobol, halton)", name));
}

Eigen::MatrixXd make_initial_design(InitialDesign design, int n, int d, std::uint64_t seed) {
  Eigen::MatrixXd points(n, d);
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  switch (design) {
    case InitialDesign::kRandom:
      for (int i = 0; i < n; ++i)
        for (int j = 0; j < d; ++j) points(i, j) = unit(rng);
      break;
    case InitialDesign::kLatinHypercube:
      // One point per stratum in every dimension, strata shuffled independently per dimension.
      for (int j = 0; j < d; ++j) {
        std::vector<int> perm(n);
        std::iota(perm.begin(), perm.end(), 0);
        std::shuffle(perm.begin(), perm.end(), rng);
        for (int i = 0; i < n; ++i) points(i, j) = (perm[i] + unit(rng)) / n;
      }
      break;
    case InitialDesign::kSobol:
    case InitialDesign::kHalton: {
      const gsl_qrng_type* type = design == InitialDesign::kSobol ? gsl_qrng_sobol : gsl_qrng_halton;
      const int max_dim = design == InitialDesign::kSobol ? 40 : 1229;
      if (d > max_dim) {
        throw InputError(fmt::format("{} design supports at most {} dimensions, got {}", to_string(design), max_dim, d));
      }
      std::unique_ptr<gsl_qrng, decltype(&gsl_qrng_free)> q(gsl_qrng_alloc(type, d), gsl_qrng_free);
      std::vector<double> shift(d);
      for (auto& s : shift) s = unit(rng);
      std::vector<double> v(d);
      for (int i = 0; i < n; ++i) {
        gsl_qrng_get(q.get(), v.data());
        for (int j = 0; j < d; ++j) points(i, j) = std::fmod(v[j] + shift[j], 1.0);
      }
      break;
    }
  }
  return points;
}

}  // namespace cpgmatch::bo
