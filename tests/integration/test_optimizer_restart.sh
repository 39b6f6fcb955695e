#!/usr/bin/env bash
# The optimizer killed with SIGKILL mid-study and restarted on the same store: the study finishes with
# every report counted exactly once.
source "$(dirname "$0")/lib.sh"
write_study "$WORK/s.yaml" optimizer-restart 40 10
start_optimizer "$WORK/s.db"
start_worker a --slots 2 --fake-rollout-ms 500
start_worker b --slots 2 --fake-rollout-ms 500
id=$(cli study submit --config "$WORK/s.yaml" --timeout 20) || fail "submit failed"
wait_until 30 completed_at_least "$id" 8 || fail "study did not get going"
kill -9 "$OPT_PID"
before=$(sql "$WORK/s.db" "select count(*) from trials where status='done'")
((before < 40)) || fail "the study ended before the optimizer was killed; the test proves nothing"
sleep 1
start_optimizer "$WORK/s.db"
wait_until 60 study_is "$id" done || fail "study did not finish after the restart"
out=$(state_json "$id")
[[ $(json_field "$out" completed) == 40 ]] || fail "completed: $out"
[[ $(sql "$WORK/s.db" "select count(*) from trials where status='done'") == 40 ]] || fail "store: not 40 done trials"
[[ $(sql "$WORK/s.db" "select count(*) from trials") == 40 ]] || fail "store: trials beyond the budget"
grep -q "resumed 1 studies" "$WORK/optimizer.log" || fail "the restarted optimizer did not resume the study"
echo "PASS optimizer restart: $before done before the kill; $out"
