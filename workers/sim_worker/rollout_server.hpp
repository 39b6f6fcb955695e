// `cpgmatch-sim-worker --serve-rollouts`: a worker slot's rollout process, kept between rollouts. It reads
// one rollout request per line on stdin (rollout_request.hpp) and answers each with one line, until its
// stdin closes:
//
//   {"report": {...}}                          the rollout's report (domain/report_json.hpp)
//   {"report": {...}, "process_ends": true}    ODE failed: a diverged report, and this process exits
//   {"unknown_spec": "1a2b3c4d5e6f7a8b"}      the request named a spec this process does not hold:
//                                              send it again with its "spec"
//   {"error": "..."}                           a malformed request (the process serves on)
//
// Answers go to the stdout it was started with; anything else in the process that prints to stdout (a
// library's message) goes to stderr instead, so it cannot be taken for an answer. Parsed specs are kept by
// key (spec_cache.hpp); each rollout builds its own ODE world.
//
// Tests only: CPGMATCH_TEST_ROLLOUT_FAULT=KIND:SEED makes the rollout of seed SEED fail after its request
// was read: KIND `abort` (SIGABRT), `hang` (never answers), `garbage` (prints a line that is no answer,
// then answers) or `ode_failure` (what ODE's failure handler does: a diverged report, then exit).
#pragma once

namespace cpgmatch::worker {

// Serves until end of input; returns the exit status.
int serve_rollouts();

}  // namespace cpgmatch::worker
