#!/usr/bin/env bash
# Benchmark: what the optimizer service and DDS cost per rollout, with the rollout replaced by a fixed
# delay (cpgmatch-sim-worker --fake-rollout-ms). Random proposals only (initial_points = budget), so
# the numbers are transport, store and scheduling, not GP fitting.
#   1. round trip: one worker, one slot, 0 ms rollouts: candidate issued -> report counted, per trial
#      (both timestamps taken by the optimizer, SQLite commits included).
#   2. throughput with 1, 2, 4, 8 workers (4 slots each, 10 ms rollouts).
# Usage: tests/bench/service_overhead.sh [build-dir] [budget per run]; writes service_overhead.png.
set -euo pipefail
build="$(cd "${1:-build}" && pwd)"; budget="${2:-3000}"
bin="$build/bin"
work=$(mktemp -d /tmp/cpgmatch-bench.XXXXXX)
domain=${BENCH_DOMAIN:-60}
pids=()
cleanup() { for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done; wait 2>/dev/null || true; }
trap cleanup EXIT
source "$(dirname "$0")/lib.sh"

run_study() {  # run_study NAME WORKERS SLOTS DELAY_MS BUDGET -> prints the store path
  local name=$1 workers=$2 slots=$3 delay=$4 n=$5 store="$work/$1.db"
  ((domain++))
  "$bin/cpgmatch-optimizer" --domain "$domain" --store "$store" --localhost-only --log-level warn 2>>"$work/opt.log" &
  local opt=$!; pids+=("$opt")
  start_fake_workers "$domain" "$workers" "$slots" "$delay"
  local ws=("${WORKER_PIDS[@]}")
  # initial_points = budget: every proposal is random and the GP is never fitted (the optimizer skips the
  # fit after the last observation; a fit on thousands of points would measure the GP, not the service).
  printf 'name: %s\nbudget: %d\ninitial_points: %d\n' "$name" "$n" "$n" >"$work/$name.yaml"
  wait_for_workers "$domain" "$workers"  # every worker announced: the run measures the steady state
  "$bin/cpgmatch" study submit --config "$work/$name.yaml" --wait --quiet --domain "$domain" --localhost-only >/dev/null
  kill "${ws[@]}" "$opt"; wait "${ws[@]}" "$opt" 2>/dev/null || true
  echo "$store"
}

echo "round trip: 1 worker, 1 slot, 0 ms rollouts, 500 trials" >&2
store=$(run_study roundtrip 1 1 0 500)
sqlite3 "$store" "select (reported_at - issued_at) * 1000 from trials" | python3 -c '
import statistics, sys
v = sorted(float(x) for x in sys.stdin)
print(f"round trip (ms): median {statistics.median(v):.2f}  p90 {v[int(0.9*len(v))]:.2f}  p99 {v[int(0.99*len(v))]:.2f}  max {v[-1]:.2f}  n={len(v)}")'

printf "# workers rollouts_per_s\n" >"$work/throughput.dat"
for w in 1 2 4 8; do
  echo "throughput: $w workers x 4 slots, 10 ms rollouts, $budget trials" >&2
  store=$(run_study "tp$w" "$w" 4 10 "$budget")
  rate=$(sqlite3 "$store" "select count(*) / (max(reported_at) - min(issued_at)) from trials")
  bound=$(python3 -c "print(f'{$w * 4 / 0.010:.0f}')")
  printf "%d %s\n" "$w" "$rate" >>"$work/throughput.dat"
  printf "throughput: %d workers: %.0f rollouts/s (bound from the delay alone: %s/s)\n" "$w" "$rate" "$bound"
done
out="$PWD/service_overhead.png"
gnuplot <<GP
set terminal pngcairo size 800,500 noenhanced
set output '$out'
set title 'Optimizer service throughput (10 ms fake rollouts, 4 slots per worker, loopback)'
set xlabel 'workers'; set ylabel 'rollouts per second'; set grid; set logscale x 2; set xtics (1,2,4,8)
set key left top
plot '$work/throughput.dat' u 1:2 w lp lw 2 pt 7 t 'measured', x*400 w l dt 2 t 'delay bound (slots / 10 ms)', 500 w l dt 3 t 'target 500/s'
GP
echo "plot: $out" >&2
rm -rf "$work"
