// Space-filling initial designs in the unit cube: random, Latin hypercube, Sobol and Halton.
// Sobol and Halton come from GSL's quasi-random generators (Sobol up to 40 dimensions, Halton up to 1229).
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

#include <Eigen/Core>

namespace cpgmatch::bo {

enum class InitialDesign { kRandom, kLatinHypercube, kSobol, kHalton };

std::string to_string(InitialDesign d);
InitialDesign initial_design_from_string(std::string_view name);  // "random", "lhs", "sobol", "halton"

// n points (rows) in [0, 1]^d. Random and LHS depend on `seed`; Sobol and Halton are scrambled by a
// seeded random shift (Cranley-Patterson rotation) so different seeds give different designs.
Eigen::MatrixXd make_initial_design(InitialDesign design, int n, int d, std::uint64_t seed);

}  // namespace cpgmatch::bo
