#include "cpgmatch/service/validation_sets.hpp"

#include <algorithm>

#include "cpgmatch/seeds.hpp"

namespace cpgmatch::service {

namespace {

// Offsets the index given to derived_seed, so the validation draws never reuse a trial's rollout seed
// (derived_seed(study seed, trial id)) for a study of fewer than a billion trials.
constexpr std::uint64_t kValidationSeedOffset = 0x56414C4944000000ULL;  // "VALID"

// A uniform number in [-1, 1) from 53 bits of a 64-bit hash: the same on every platform and standard
// library (std::uniform_real_distribution is not specified bit for bit).
double symmetric_unit(std::uint64_t bits) {
  const double u = static_cast<double>(bits >> 11) * 0x1.0p-53;  // [0, 1)
  return 2.0 * u - 1.0;
}

}  // namespace

std::vector<Eigen::VectorXd> validation_sets(const bo::SearchSpace& space, const Eigen::VectorXd& centre, int n,
                                             double spread, std::uint64_t seed) {
  std::vector<Eigen::VectorXd> sets;
  const auto& dims = space.dimensions();
  for (int i = 0; i < n; ++i) {
    const std::uint64_t set_seed = derived_seed(seed, kValidationSeedOffset + static_cast<std::uint64_t>(i));
    Eigen::VectorXd x = centre;
    for (int d = 0; d < static_cast<int>(dims.size()) && d < centre.size(); ++d) {
      const double factor = 1.0 + spread * symmetric_unit(derived_seed(set_seed, static_cast<std::uint64_t>(d)));
      x[d] = std::clamp(centre[d] * factor, dims[d].low, dims[d].high);
    }
    sets.push_back(std::move(x));
  }
  return sets;
}

}  // namespace cpgmatch::service
