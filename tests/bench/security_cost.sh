#!/usr/bin/env bash
# Benchmark, run by hand: what DDS-Security costs. The same studies plain and secure (keystore from
# deploy/make-study-pki.sh, every topic encrypted), on loopback:
#   1. round trip: 1 worker, 1 slot, 0 ms fake rollouts, random proposals only: wall time per trial
#   2. the paper's study (150 real rollouts, 20 s each), WORKERS workers with 1 slot: wall time
# Usage: tests/bench/security_cost.sh [build-dir] [round-trip trials, default 300] [workers, default 2]
set -euo pipefail
build="$(cd "${1:-build}" && pwd)"; trials=${2:-300}; workers=${3:-2}
bin="$build/bin"
work=$(mktemp -d /tmp/cpgmatch-seccost.XXXXXX)
domain=${BENCH_DOMAIN:-55}
pids=()
cleanup() { for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done; wait 2>/dev/null || true; rm -rf "$work"; }
trap cleanup EXIT
"$(dirname "$0")/../../deploy/make-study-pki.sh" "$work/ks" >/dev/null

# timed_study NAME YAML WORKERS FAKE_MS [security flags]: prints the wall time of submit --wait (s)
timed_study() {
  local name=$1 yaml=$2 n=$3 fake=$4; shift 4
  ((domain++))
  "$bin/cpgmatch-optimizer" --domain "$domain" --store "$work/$name.db" --localhost-only --log-level warn "$@" \
    2>>"$work/opt.log" &
  local opt=$!; pids+=("$opt")
  local ws=() extra=()
  [[ $fake != - ]] && extra=(--fake-rollout-ms "$fake")
  for i in $(seq "$n"); do
    "$bin/cpgmatch-sim-worker" --domain "$domain" --id "worker/w$i" --slots 1 "${extra[@]}" --localhost-only --log-level warn \
      "$@" 2>>"$work/workers.log" &
    ws+=($!); pids+=($!)
  done
  until [[ $("$bin/cpgmatch" workers --json --domain "$domain" --localhost-only --timeout 5 "$@" 2>/dev/null |
             python3 -c 'import json,sys; print(len(json.load(sys.stdin)))') -ge $n ]]; do sleep 0.2; done
  local t0; t0=$(date +%s.%N)
  "$bin/cpgmatch" study submit --config "$yaml" --wait --quiet --domain "$domain" --localhost-only --timeout 30 "$@" \
    >/dev/null
  python3 -c "import sys; print(f'{float(sys.argv[2]) - float(sys.argv[1]):.2f}')" "$t0" "$(date +%s.%N)"
  kill "${ws[@]}" "$opt"; wait "${ws[@]}" "$opt" 2>/dev/null || true
}

printf 'name: roundtrip\nbudget: %d\ninitial_points: %d\n' "$trials" "$trials" >"$work/rt.yaml"
printf 'name: paper\n' >"$work/paper.yaml"
for mode in plain secure; do
  flags=(); [[ $mode == secure ]] && flags=(--keystore "$work/ks")
  s=$(timed_study "rt-$mode" "$work/rt.yaml" 1 0 "${flags[@]}")
  python3 -c "import sys; print(f'{sys.argv[1]}: round trip {float(sys.argv[2]) * 1000 / int(sys.argv[3]):.2f} ms per trial ({sys.argv[3]} trials in {sys.argv[2]} s)')" "$mode" "$s" "$trials"
done
for mode in plain secure; do
  flags=(); [[ $mode == secure ]] && flags=(--keystore "$work/ks")
  s=$(timed_study "paper-$mode" "$work/paper.yaml" "$workers" - "${flags[@]}")
  echo "$mode: paper study (150 rollouts, $workers workers x 1 slot) in $s s"
done
