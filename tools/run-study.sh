#!/usr/bin/env bash
# README command one: install what is missing, build, run the paper's study on the embedded default.
# Extra arguments go to `cpgmatch study run`.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
# Only what the study runs: the CLI and the two processes it starts (tools/cpgmatch/local_study.cpp). The
# test programs, the robot agent and the benchmarks are built by tools/run-tests.sh (or tools/build.sh).
"$root/tools/build.sh" cpgmatch cpgmatch-optimizer cpgmatch-sim-worker
exec "$root/build/bin/cpgmatch" study run "$@"
