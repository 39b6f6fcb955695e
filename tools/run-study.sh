#!/usr/bin/env bash
# README command one: install what is missing, build, run the paper's study on the embedded default.
# Extra arguments go to `cpgmatch study run`.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$root/tools/build.sh"
exec "$root/build/bin/cpgmatch" study run "$@"
