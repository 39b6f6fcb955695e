// The rollout request a worker slot sends to its rollout process, and running one. The request carries the
// candidate's parameters, terrain, seed and timing, the key of the study spec it runs and, unless the
// process already holds that spec, the spec itself (the child reads no local config):
//
//   {"params": {...}, "entrain_s": 0.5, "eval_s": 0.5, "terrain": "flat", "seed": 7,
//    "spec_key": "1a2b3c4d5e6f7a8b", "spec": "<the spec's canonical JSON>"}
//
// `--run-one` takes one such request (with its spec) on stdin; `--serve-rollouts` one per line
// (rollout_server.hpp).
#pragma once

#include <nlohmann/json.hpp>

#include "cpgmatch/domain/candidate.hpp"
#include "cpgmatch/study/study_spec.hpp"

namespace cpgmatch::worker {

// `with_spec`: false once the process is known to hold the spec (it parsed it for an earlier request).
nlohmann::json rollout_request(const domain::Candidate& c, const study::StudySpec& spec, bool with_spec = true);

// Runs one request's rollout of `spec` in this process; its report as JSON (domain/report_json.hpp).
// Throws InputError for a malformed request.
nlohmann::json run_rollout(const study::StudySpec& spec, const nlohmann::json& request);

// The same for a request that carries its spec, parsed here (`--run-one`).
nlohmann::json run_rollout_request(const nlohmann::json& request);

}  // namespace cpgmatch::worker
