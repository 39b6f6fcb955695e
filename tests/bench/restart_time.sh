#!/usr/bin/env bash
# Benchmark: time from starting cpgmatch-optimizer on a store of N results until it serves (its
# "resumed" log line), after a SIGKILL. Usage: tests/bench/restart_time.sh BUILD_DIR N INITIAL [DOMAIN]
# INITIAL random points come first (no model); every result after them refits the GP while the store is
# built, so keep N - INITIAL small for large N. Run by hand.
set -euo pipefail
BIN="$(cd "$1" && pwd)/bin"; N=$2; INITIAL=$3; DOMAIN=${4:-88}
export BIN DOMAIN
source "$(dirname "$0")/../integration/lib.sh"
write_study "$WORK/s.yaml" restart-bench "$N" "$INITIAL"
start_optimizer "$WORK/s.db"
start_worker a --slots 4 --fake-rollout-ms 1
id=$(cli study submit --config "$WORK/s.yaml" --timeout 20) || fail "submit failed"
build_start=$SECONDS
wait_until 3600 study_is "$id" done || fail "study did not finish"
echo "store of $N results ($INITIAL random) built in $((SECONDS - build_start)) s"
kill -9 "$OPT_PID"
sleep 0.5
: >"$WORK/optimizer.log"
t0=$(date +%s.%N)
start_optimizer "$WORK/s.db"
wait_until 600 grep -q "resumed 1 studies" "$WORK/optimizer.log" || fail "no resume"
t1=$(date +%s.%N)
python3 -c "import sys; print(f'restart until serving: {float(sys.argv[2]) - float(sys.argv[1]):.3f} s with $N results in the store')" "$t0" "$t1"
