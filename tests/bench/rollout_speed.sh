#!/usr/bin/env bash
# Benchmark: wall time and peak memory of one 20 s rollout (20,000 physics steps) on one core, and the
# wall time of the matched trot when as many rollouts run at once as there are cores: what a local study's
# workers get (on a host whose vCPUs share physical cores, or are shared with other guests, each rollout is
# slower then, and the paper study with it).
# Usage: tests/bench/rollout_speed.sh [build-dir] [repetitions]
set -euo pipefail
build="${1:-build}"; reps="${2:-10}"
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
for preset in matched-trot unmatched; do
  params="$root/configs/params/$preset.yaml"
  walls=""
  for _ in $(seq "$reps"); do
    walls+="$("$build/bin/cpgmatch" rollout --params "$params" --json | python3 -c 'import json,sys; print(json.load(sys.stdin)["wall_time_s"])') "
  done
  peak_kb=$( { /usr/bin/time -f '%M' "$build/bin/cpgmatch" rollout --params "$params" --json >/dev/null; } 2>&1 | tail -1)
  python3 - "$preset" "$peak_kb" $walls <<'PY'
import statistics, sys
preset, peak_kb, walls = sys.argv[1], int(sys.argv[2]), [float(w) for w in sys.argv[3:]]
print(f"{preset}: 20 s rollout wall median {statistics.median(walls):.3f} s, max {max(walls):.3f} s "
      f"over {len(walls)} runs; peak RSS {peak_kb / 1024:.1f} MB")
PY
done

cores=$(nproc)
params="$root/configs/params/matched-trot.yaml"
walls=""
for _ in $(seq "$reps"); do
  out=$(for _ in $(seq "$cores"); do "$build/bin/cpgmatch" rollout --params "$params" --json & done; wait)
  walls+="$(python3 -c 'import json,sys; print(" ".join(str(json.loads(l)["wall_time_s"]) for l in sys.stdin if l.strip()))' <<<"$out") "
done
python3 - "$cores" $walls <<'PY'
import statistics, sys
cores, walls = int(sys.argv[1]), [float(w) for w in sys.argv[2:]]
print(f"matched-trot, {cores} at once: wall median {statistics.median(walls):.3f} s, max {max(walls):.3f} s over {len(walls)} rollouts")
PY
