// The validation phase's parameter sets: N points around a study's answer, each optimised parameter
// varied by at most +-spread of its own value (relative, as the paper's "+-10%"), clipped to the search
// space's bounds. A pure function of its inputs: the same study seed gives the same sets, so a restart
// (or a rerun of the same study) validates the same points.
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "cpgmatch/bo/search_space.hpp"

namespace cpgmatch::service {

// A parameter whose value is 0 stays 0 (a relative spread of zero is zero).
std::vector<Eigen::VectorXd> validation_sets(const bo::SearchSpace& space, const Eigen::VectorXd& centre, int n,
                                             double spread, std::uint64_t seed);

}  // namespace cpgmatch::service
