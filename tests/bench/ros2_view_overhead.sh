#!/usr/bin/env bash
# Benchmark: what the ROS 2 view (docs/ros2.md) costs the optimizer. The same study of random proposals with
# fake rollouts (4 workers x 4 slots, 10 ms), with the view and with --no-ros2-view, alternating, REPEATS
# times each: wall time of `study submit --wait`, the optimizer's CPU time for the whole run (startup included)
# and its own event-loop latency (logged at exit).
# Usage: tests/bench/ros2_view_overhead.sh [build-dir] [budget] [repeats]   (DDS domain $BENCH_DOMAIN, 81)
set -euo pipefail
build="$(cd "${1:-build}" && pwd)"; budget="${2:-1000}"; repeats="${3:-3}"
bin="$build/bin"
work=$(mktemp -d /tmp/cpgmatch-bench.XXXXXX)
domain=${BENCH_DOMAIN:-81}
pids=()
cleanup() { for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done; wait 2>/dev/null || true; }
trap cleanup EXIT
source "$(dirname "$0")/lib.sh"

run() {  # run LABEL [optimizer flags]: prints "LABEL SECONDS LATENCY-SUMMARY"
  local label=$1; shift
  local store="$work/$label-$RANDOM.db" log="$work/opt-$label-$RANDOM.log"
  "$bin/cpgmatch-optimizer" --domain "$domain" --store "$store" --localhost-only "$@" 2>"$log" &
  local opt=$!; pids+=("$opt")
  start_fake_workers "$domain" 4 4 10
  local ws=("${WORKER_PIDS[@]}")
  printf 'name: bench\nbudget: %d\ninitial_points: %d\n' "$budget" "$budget" >"$work/s.yaml"
  wait_for_workers "$domain" 4
  local t0=$EPOCHREALTIME
  "$bin/cpgmatch" study submit --config "$work/s.yaml" --wait --quiet --domain "$domain" --localhost-only >/dev/null
  local t1=$EPOCHREALTIME
  # The optimizer's CPU time (user + system, clock ticks in /proc/PID/stat), less sensitive than wall time
  # to other work on the machine.
  local cpu
  cpu=$(awk -v hz="$(getconf CLK_TCK)" '{printf "%.2f", ($14 + $15) / hz}' "/proc/$opt/stat")
  kill -TERM "${ws[@]}" "$opt"; wait "${ws[@]}" "$opt" 2>/dev/null || true
  printf '%s: wall %.2f s, optimizer CPU %s s | %s\n' "$label" "$(echo "$t1 - $t0" | bc)" "$cpu" \
    "$(grep -o 'sample arrival to handled: [^;]*' "$log" | tail -n 1)"
}

for ((i = 0; i < repeats; ++i)); do
  run view
  run no-view --no-ros2-view
done
