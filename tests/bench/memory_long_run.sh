#!/usr/bin/env bash
# Benchmark (run by hand, not in ctest): does the optimizer's memory stay flat over a long run? Submits
# STUDIES studies of TRIALS random trials each (initial_points = budget: no GP, so the run measures the
# service's bookkeeping, DDS histories and store, not model sizes), BATCH at a time, to 2 workers x 16
# slots of 5-ms fake rollouts, and prints the optimizer's RSS (VmRSS) after every batch.
# Usage: tests/bench/memory_long_run.sh [build-dir] [STUDIES=150] [TRIALS=40] [BATCH=10]
#   OPTIMIZER=/path/to/cpgmatch-optimizer: another build's optimizer (a before/after comparison)
set -euo pipefail
build="$(cd "${1:-build}" && pwd)"; studies=${2:-150}; trials=${3:-40}; batch=${4:-10}
bin="$build/bin"
work=$(mktemp -d /tmp/cpgmatch-bench.XXXXXX)
domain=${BENCH_DOMAIN:-90}
pids=()
cleanup() { for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done; wait 2>/dev/null || true; rm -rf "$work"; }
trap cleanup EXIT
source "$(dirname "$0")/lib.sh"
rss_kb() { awk '/VmRSS/ {print $2}' "/proc/$1/status"; }

"${OPTIMIZER:-$bin/cpgmatch-optimizer}" --domain "$domain" --store "$work/s.db" --localhost-only --log-level warn 2>"$work/opt.log" &
opt=$!; pids+=("$opt")
start_fake_workers "$domain" 2 16 5
wait_for_workers "$domain" 2
start=$SECONDS
echo "studies_done trials_done rss_mb elapsed_s"
echo "0 0 $(python3 -c "print(f'{$(rss_kb "$opt") / 1024:.1f}')") 0"
submitted=0
while ((submitted < studies)); do
  n=$((studies - submitted < batch ? studies - submitted : batch))
  for k in $(seq "$n"); do
    printf 'name: mem-%d\nbudget: %d\ninitial_points: %d\nseed: %d\n' "$((submitted + k))" "$trials" "$trials" "$k" \
      >"$work/m.yaml"
    # (timeout: a Fast DDS 2.9 client was seen hanging at exit with data sharing on, after its reply)
    timeout 30 "$bin/cpgmatch" study submit --config "$work/m.yaml" --timeout 20 --domain "$domain" --localhost-only >/dev/null || true
  done
  submitted=$((submitted + n))
  until [[ $(sqlite3 "$work/s.db" "select count(*) from trials where status = 'done'") -ge $((submitted * trials)) ]]; do
    sleep 0.5
  done
  echo "$submitted $((submitted * trials)) $(python3 -c "print(f'{$(rss_kb "$opt") / 1024:.1f}')") $((SECONDS - start))"
done
sleep 35  # finished studies' records leave the DDS writer 30 s after the study ended
echo "after 35 s idle: $(python3 -c "print(f'{$(rss_kb "$opt") / 1024:.1f}')") MB"
