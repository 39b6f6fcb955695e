// A worker's view of study specs: the spec a candidate names, parsed once and kept, or the reason the
// worker must refuse the candidate (study_spec.hpp). Shared by cpgmatch-sim-worker and the robot agent.
#pragma once

#include <chrono>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>

#include "cpgmatch/study/study_spec.hpp"
#include "cpgmatch/worker/worker_link.hpp"

namespace cpgmatch::worker {

class SpecBook {
 public:
  // `objective_version`: what this worker computes (study::kObjectiveVersion; tests pass another to play
  // an older or newer release).
  SpecBook(WorkerLink& link, int objective_version) : link_(link), objective_version_(objective_version) {}

  struct Lookup {
    std::shared_ptr<const study::StudySpec> spec;  // null: refuse, for `refusal`
    std::string refusal;
  };
  // The spec with this key. Waits up to `wait` for it to arrive; refuses a spec of another objective
  // version, one whose content does not match its hash, and one that does not parse.
  Lookup find(std::uint64_t key, std::chrono::milliseconds wait = std::chrono::seconds(5));

  int objective_version() const { return objective_version_; }

 private:
  WorkerLink& link_;
  int objective_version_;
  std::mutex mutex_;
  std::map<std::uint64_t, std::shared_ptr<const study::StudySpec>> parsed_;
};

}  // namespace cpgmatch::worker
