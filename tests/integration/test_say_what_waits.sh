#!/usr/bin/env bash
# What is wrong is said, not left to be guessed: a worker that hears no optimizer says so in its log (after
# 10 s, WorkerLink::kOptimizerSilence) and again when one appears; a study submitted while no simulation
# worker is on the domain says "waiting for simulation workers: none on domain D" in its state, `submit
# --wait` prints it, and it runs once a worker joins; `cpgmatch workers` never misses a heartbeating worker.
source "$(dirname "$0")/lib.sh"
start_worker lonely --slots 1 --fake-rollout-ms 20
wait_until 20 grep -q "no optimizer on DDS domain $DOMAIN for 10 s" "$WORK/worker-lonely.log" ||
  fail "the worker did not say that it hears no optimizer"
kill "$WORKER_PID"; wait "$WORKER_PID" 2>/dev/null || true

write_study "$WORK/s.yaml" waits 4
start_optimizer "$WORK/s.db"
"$BIN/cpgmatch" study submit --config "$WORK/s.yaml" --wait --timeout 20 --domain "$DOMAIN" --localhost-only \
  >"$WORK/submit.out" 2>"$WORK/submit.err" &
SUBMIT=$!
PIDS+=("$SUBMIT")
wait_until 30 grep -q "waiting for simulation workers: none on domain $DOMAIN" "$WORK/submit.err" ||
  fail "submit --wait did not print what the study waits for"
out=$(state_json 1)
[[ $(json_field "$out" state) == running ]] || fail "state: $out"
[[ $out == *"waiting for simulation workers: none on domain $DOMAIN"* ]] || fail "state message: $out"
start_worker w --slots 2 --fake-rollout-ms 20
wait "$SUBMIT" || fail "submit --wait did not end well once a worker joined"
# `workers` waits for discovery: every one of 8 fresh clients lists the heartbeating worker.
for i in 1 2 3 4 5 6 7 8; do
  listed=$(cli workers --json --timeout 5) || fail "workers failed"
  [[ $listed == *'"worker_id":"w"'* ]] || fail "workers call $i missed the heartbeating worker: $listed"
done
grep -q "an optimizer is on domain $DOMAIN\|no optimizer" "$WORK/worker-w.log" && fail "a worker with an optimizer complained"
out=$(state_json 1)
[[ $(json_field "$out" state) == done ]] || fail "state: $out"
[[ $out != *"waiting for simulation"* ]] || fail "the finished study still waits: $out"
echo "PASS say what waits: $(grep -m1 -o 'waiting for simulation workers: none on domain [0-9]*' "$WORK/submit.err")"
