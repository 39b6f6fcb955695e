// What one worker slot does with one candidate: validate it, run the rollout (in a child process, or a
// fixed delay for service benchmarks) and turn the outcome into a report. Never throws for a bad
// candidate or a crashing rollout: those become reports that did not measure, with the reason. Domain types
// only: the worker's link (worker_link.hpp) converts to and from the wire.
#pragma once

#include <functional>
#include <string>

#include <nlohmann/json.hpp>

#include "cpgmatch/worker/spec_book.hpp"
#include "cpgmatch/domain/candidate.hpp"

namespace cpgmatch::worker {

struct SlotOptions {
  std::string worker_id;
  double fake_rollout_s = -1.0;  // >= 0: no simulation, sleep this long and report a synthetic cost
  // The spec a candidate names, or why to refuse it (SpecBook::find).
  std::function<SpecBook::Lookup(std::uint64_t spec_key)> find_spec;
};

// The rollout request a slot hands to its child process (`cpgmatch-sim-worker --run-one`): the candidate's
// parameters, terrain, seed and timing, and the whole spec it runs (the child reads no local config).
nlohmann::json rollout_request(const domain::Candidate& c, const study::StudySpec& spec);

// Runs one rollout request in this process and returns its report as JSON (domain/report_json.hpp).
// Throws InputError for a malformed request.
nlohmann::json run_rollout_request(const nlohmann::json& request);

// Validates, runs and reports one candidate. Thread-safe: each call forks its own rollout process.
domain::RolloutReport execute_candidate(const domain::Candidate& c, const SlotOptions& options);

}  // namespace cpgmatch::worker
