// The study specs a rollout process has parsed, by key, so that the second rollout of a study does not
// parse its spec again. Bounded: a worker serving many studies keeps the most recently used few; the slot
// sends an evicted spec again when the process says it does not hold it (rollout_server.hpp).
//
// Only the parsed spec is kept, never a built ODE world: a rollout builds its own world (run_sim_rollout),
// which costs well under a millisecond and keeps each rollout computing exactly what it computes in a
// fresh process.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include "cpgmatch/study/study_spec.hpp"

namespace cpgmatch::worker {

class SpecCache {
 public:
  explicit SpecCache(std::size_t capacity = 8) : capacity_(capacity) {}

  // The spec with this key, or null; marks it most recently used.
  std::shared_ptr<const study::StudySpec> find(std::uint64_t key);
  // Keeps `spec` under its own key, evicting the least recently used beyond the capacity.
  void keep(std::shared_ptr<const study::StudySpec> spec);

  std::size_t size() const { return specs_.size(); }

 private:
  std::size_t capacity_;
  std::vector<std::shared_ptr<const study::StudySpec>> specs_;  // most recently used last
};

}  // namespace cpgmatch::worker
