#!/usr/bin/env bash
# Installs missing packages, then configures and builds cpgmatch (Release) into ./build.
# Usage: tools/build.sh [TARGET...]: only the given targets (and what they need); none given: every target,
# the test programs included.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$root/deploy/install-deps.sh"
jobs="$(nproc 2>/dev/null || echo 2)"
cmake -S "$root" -B "$root/build" -DCMAKE_BUILD_TYPE=Release >/dev/null
if (($# > 0)); then
  cmake --build "$root/build" -j "$jobs" --target "$@"
else
  cmake --build "$root/build" -j "$jobs"
fi
