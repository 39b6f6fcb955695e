// Seeds derived from seeds: one rollout seed per trial (or per jitter draw) from a study's seed.
#pragma once

#include <cstdint>

namespace cpgmatch {

// splitmix64 of (seed, index): neighbouring indices get unrelated seeds, the same pair always the same
// one. Every trial of a study uses derived_seed(study seed, trial id) for its sensor noise and rough ground.
std::uint64_t derived_seed(std::uint64_t seed, std::uint64_t index);

}  // namespace cpgmatch
