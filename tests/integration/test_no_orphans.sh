#!/usr/bin/env bash
# Issue 34: no orphaned processes, no silent failure of `study run`.
#  1. `study run` with 10-minute rollouts gets SIGTERM, SIGINT, then SIGHUP mid-rollout: it exits, and every
#     process it started (optimizer, workers and their rollout processes, `--serve-rollouts`) is gone.
#  2. A worker SIGKILLed mid-rollout: its rollout process dies with it (PR_SET_PDEATHSIG).
#  3. A study whose every trial fails (each rollout killed by a 0.01 s lease): `study run` exits 1 saying so.
# Processes are found by a marker in their environment (inherited by every descendant), not by name, so the
# test sees exactly its own processes, with their command lines or without.
source "$(dirname "$0")/lib.sh"

marked() {  # marked MARK: pids of live processes whose environment holds CPGMATCH_TEST_MARK=MARK
  local p
  for p in /proc/[0-9]*; do
    tr '\0' '\n' <"$p/environ" 2>/dev/null | grep -qx "CPGMATCH_TEST_MARK=$1" && echo "${p#/proc/}"
  done
  return 0
}
rollout_running() { for p in $(marked "$1"); do grep -qE -- "--run-one|--serve-rollouts" "/proc/$p/cmdline" 2>/dev/null && return 0; done; return 1; }
none_marked() { [[ -z $(marked "$1") ]]; }
describe() { for p in $(marked "$1"); do echo "$p: $(tr '\0' ' ' <"/proc/$p/cmdline" 2>/dev/null)"; done; }

cat >"$WORK/long.yaml" <<YAML
name: long-rollouts
budget: 4
initial_points: 4
seed: 3
rollout: {entrain_s: 600, eval_s: 600}
YAML

for sig in TERM INT HUP; do
  mark="$WORK-$sig"
  CPGMATCH_TEST_MARK=$mark "$BIN/cpgmatch" study run --config "$WORK/long.yaml" --workers 2 --out "$WORK/run-$sig" \
    --domain "$DOMAIN" --quiet --jitter 0 >"$WORK/run-$sig.log" 2>&1 &
  run_pid=$!
  PIDS+=("$run_pid")
  wait_until 60 rollout_running "$mark" || fail "SIG$sig: no rollout process started: $(describe "$mark")"
  before=$(marked "$mark" | wc -l)
  kill -s "$sig" "$run_pid"
  started=$SECONDS
  rc=0
  wait "$run_pid" || rc=$?
  ((rc != 0)) || fail "SIG$sig: study run exited 0 after being interrupted"
  wait_until 10 none_marked "$mark" || fail "SIG$sig: processes left after study run exited: $(describe "$mark")"
  grep -q "interrupted" "$WORK/run-$sig.log" || fail "SIG$sig: study run did not say it was interrupted"
  echo "PASS SIG$sig to study run mid-rollout: $before processes before, none after, exit $rc after $((SECONDS - started)) s"
done

# 2. A worker killed with SIGKILL mid-rollout: nothing can run in it, only the kernel can end its child.
mark="$WORK-worker"
start_optimizer "$WORK/w.db"
CPGMATCH_TEST_MARK=$mark start_worker w1 --slots 1
cli study submit --config "$WORK/long.yaml" >/dev/null
wait_until 60 rollout_running "$mark" || fail "worker: no rollout process started: $(describe "$mark")"
kill -9 "$WORKER_PID"
wait_until 5 none_marked "$mark" || fail "the rollout process outlived its SIGKILLed worker: $(describe "$mark")"
echo "PASS worker SIGKILL mid-rollout: its rollout process died with it"
kill "$OPT_PID"

# 3. Every trial fails: each rollout process is killed at its 0.01 s lease.
cat >"$WORK/fail.yaml" <<YAML
name: all-fail
budget: 3
initial_points: 3
seed: 3
lease_s: 0.01
rollout: {entrain_s: 0.5, eval_s: 0.5}
YAML
rc=0
"$BIN/cpgmatch" study run --config "$WORK/fail.yaml" --workers 1 --out "$WORK/run-fail" --domain "$DOMAIN" --quiet \
  --jitter 0 >"$WORK/run-fail.log" 2>&1 || rc=$?
((rc == 1)) || fail "study run of a study whose every trial failed exited $rc (want 1): $(tail -3 "$WORK/run-fail.log")"
grep -q "every one of its 3 trials failed" "$WORK/run-fail.log" || fail "no reason given: $(tail -3 "$WORK/run-fail.log")"
echo "PASS every trial failed: study run exits 1: $(grep -o 'every one.*' "$WORK/run-fail.log" | head -c 160)"
