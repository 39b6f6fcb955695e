#!/usr/bin/env bash
# Malformed samples (NaN cost, unknown study, never-issued candidate, forged worker key, bad study
# files, NaN parameters, unknown terrain) are rejected with a logged reason; the optimizer and the
# worker keep running and the study finishes intact.
source "$(dirname "$0")/lib.sh"
write_study "$WORK/s.yaml" malformed 30
start_optimizer "$WORK/s.db"
start_worker w --slots 2 --fake-rollout-ms 50; W=$WORKER_PID
id=$(cli study submit --config "$WORK/s.yaml" --timeout 20) || fail "submit failed"
"$BIN/inject_malformed" "$DOMAIN" "$id" w >"$WORK/inject.log" 2>&1 || fail "injector failed"
wait_until 60 study_is "$id" done || fail "study did not finish"
kill -0 "$OPT_PID" || fail "optimizer died"
kill -0 "$W" || fail "worker died"
out=$(state_json "$id")
[[ $(json_field "$out" completed) == 30 ]] || fail "completed: $out"
[[ $(json_field "$out" failed) == 0 ]] || fail "a malformed sample reached the study: $out"
[[ $(sql "$WORK/s.db" "select count(*) from trials where status='done'") == 30 ]] || fail "store: not 30 done trials"
[[ $(sql "$WORK/s.db" "select count(*) from studies") == 1 ]] || fail "a bad submit created a study"
for reason in "cost is not finite" "unknown study" "no such candidate was ever issued" "worker_key is not the hash" "no_such_parameter" "no study 4242"; do
  grep -q "$reason" "$WORK/optimizer.log" || fail "optimizer log does not mention: $reason"
done
grep -q "bad parameters" "$WORK/worker-w.log" || fail "worker log does not mention the NaN parameters"
grep -q "bad rollout spec" "$WORK/worker-w.log" || fail "worker log does not mention the bad terrain"
echo "PASS malformed samples: $out"
