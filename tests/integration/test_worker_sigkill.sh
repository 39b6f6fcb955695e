#!/usr/bin/env bash
# A worker killed with SIGKILL mid-rollout: its candidates are re-issued and the study still ends with
# exactly `budget` observations.
source "$(dirname "$0")/lib.sh"
write_study "$WORK/s.yaml" worker-sigkill 24
start_optimizer "$WORK/s.db"
start_worker doomed --slots 2 --fake-rollout-ms 1000; DOOMED=$WORKER_PID
start_worker survivor --slots 2 --fake-rollout-ms 1000
id=$(cli study submit --config "$WORK/s.yaml" --timeout 20) || fail "submit failed"
wait_until 30 completed_at_least "$id" 4 || fail "study did not start"
kill -9 "$DOOMED"
before=$(sql "$WORK/s.db" "select count(*) from trials where status='done'")
((before < 24)) || fail "the study ended before the worker was killed; the test proves nothing"
wait_until 60 study_is "$id" done || fail "study did not finish after the worker was killed"
out=$(state_json "$id")
[[ $(json_field "$out" completed) == 24 ]] || fail "completed: $out"
[[ $(json_field "$out" reissued) -ge 1 ]] || fail "nothing was re-issued: $out"
[[ $(sql "$WORK/s.db" "select count(*) from trials where status='done'") == 24 ]] || fail "store: not 24 done trials"
[[ $(sql "$WORK/s.db" "select count(*) from trials") == 24 ]] || fail "store: more trials than the budget"
echo "PASS worker SIGKILL: $out"
