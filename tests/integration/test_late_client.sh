#!/usr/bin/env bash
# A client process started after the study ended still gets its final state (transient-local state).
source "$(dirname "$0")/lib.sh"
write_study "$WORK/s.yaml" late-client 10
start_optimizer "$WORK/s.db"
start_worker a --slots 2 --fake-rollout-ms 20; A=$WORKER_PID
cli study submit --config "$WORK/s.yaml" --wait --quiet --timeout 20 >/dev/null || fail "submit --wait failed"
kill -TERM "$A"; wait "$A" || true
out=$(cli status --study 1 --json --timeout 10) || fail "status failed"
[[ $(json_field "$out" state) == done ]] || fail "state: $out"
[[ $(json_field "$out" completed) == 10 ]] || fail "completed: $out"
[[ -n $(json_field "$out" best_params) ]] || fail "no best params: $out"
all=$(cli status --json --timeout 10)
[[ $(python3 -c 'import json,sys; print(len(json.loads(sys.argv[1])))' "$all") == 1 ]] || fail "status --json: $all"
echo "PASS late client: $out"
