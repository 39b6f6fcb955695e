#!/usr/bin/env bash
# Benchmark: wall time and peak memory of one 20 s rollout (20,000 physics steps) on one core.
# Usage: tests/bench/rollout_speed.sh [build-dir] [repetitions]
set -euo pipefail
build="${1:-build}"; reps="${2:-10}"
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
for preset in matched-trot unmatched; do
  walls=()
  for _ in $(seq "$reps"); do
    walls+=("$("$build/bin/cpgmatch" rollout --params "$root/configs/params/$preset.yaml" --json | python3 -c 'import json,sys; print(json.load(sys.stdin)["wall_time_s"])')")
  done
  mem=$( { /usr/bin/time -f '%M' "$build/bin/cpgmatch" rollout --params "$root/configs/params/$preset.yaml" --json >/dev/null; } 2>&1 | tail -1)
  python3 -c "
import statistics,sys
w=[float(x) for x in sys.argv[2:]]
print(f'{sys.argv[1]}: 20 s rollout wall median {statistics.median(w):.3f} s, max {max(w):.3f} s over {len(w)} runs; peak RSS {int(sys.argv[1+0] and 0) or 0}')" "$preset" "${walls[@]}" | sed "s/peak RSS 0/peak RSS $((mem/1024)) MB/"
done
