#!/usr/bin/env bash
# README command two: install what is missing, build, run every test with ctest.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$root/tools/build.sh"
jobs="$(nproc 2>/dev/null || echo 2)"
cd "$root/build"
ctest --output-on-failure -j "$jobs" "$@"
