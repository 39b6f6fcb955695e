#!/usr/bin/env bash
# Benchmark: cpgmatch's optimizer with the paper's budget (150 evaluations, 15 initial, gp_hedge) on
# the reference functions, seeds 0-9; prints per-seed rows and the median regret and proposal time,
# to compare with shared/anchors/baselines.md (scikit-optimize gp_minimize).
# Usage: tests/bench/optimizer_vs_skopt.sh [build-dir] [functions...]
set -euo pipefail
build="${1:-build}"; shift || true
functions=("${@:-branin hartmann6}")
[ $# -gt 0 ] || functions=(branin hartmann6)
bin="$build/bin/cpgmatch"
out="$(mktemp)"
for f in "${functions[@]}"; do
  for seed in 0 1 2 3 4 5 6 7 8 9; do
    "$bin" bench-optimizer --function "$f" --budget 150 --initial 15 --acq gp_hedge --seed "$seed" --quiet --json >>"$out"
    echo "  $f seed $seed done" >&2
  done
done
python3 - "$out" <<'PY'
import json, statistics, sys
rows = [json.loads(l) for l in open(sys.argv[1])]
by = {}
for r in rows: by.setdefault(r["function"], []).append(r)
print("| function | median regret | per-seed regret | median wall s | median last proposal ms | max last proposal ms |")
print("|---|---|---|---|---|---|")
for f, rs in by.items():
    reg = [r["regret"] for r in rs]
    print(f"| {f} | {statistics.median(reg):.3g} | {' '.join(f'{x:.2g}' for x in reg)} | "
          f"{statistics.median(r['wall_time_s'] for r in rs):.2f} | "
          f"{statistics.median(r['proposal_ms_last'] for r in rs):.1f} | {max(r['proposal_ms_last'] for r in rs):.1f} |")
PY
