#!/usr/bin/env bash
# Long-lived workers outlive their optimizer: a new optimizer on a fresh store reuses study and trial ids
# the workers have already run, and its study must still complete.
source "$(dirname "$0")/lib.sh"
write_study "$WORK/s.yaml" fresh-store 8 8
start_optimizer "$WORK/a.db"
start_worker w --slots 2 --fake-rollout-ms 20
id=$(cli study submit --config "$WORK/s.yaml" --timeout 20) || fail "first submit failed"
wait_until 60 study_is "$id" done || fail "the first study did not finish"
kill "$OPT_PID"
wait "$OPT_PID" 2>/dev/null || true
start_optimizer "$WORK/b.db"
id2=$(cli study submit --config "$WORK/s.yaml" --timeout 20) || fail "second submit failed"
[[ $id2 == "$id" ]] || fail "expected the fresh store to reuse study id $id, got $id2 (the test would prove nothing)"
wait_until 60 study_is "$id2" done || fail "the fresh store's study did not finish with the same workers: $(state_json "$id2")"
echo "PASS fresh store: study $id2 completed again with the long-lived worker"
