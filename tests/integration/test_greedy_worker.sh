#!/usr/bin/env bash
# A slot count is a claim, not a right (no DDS-Security needed): a worker that announces 16 slots, takes its
# candidates and never answers loses them at their lease (6 s here) and is then on probation: it holds at
# most one candidate at a time (2 allowed for the two clocks) and gets work only when the honest worker has
# no free slot. The study completes through the honest worker.
#   BIN=build/bin DOMAIN=61 ROGUE=build/bin/rogue_worker test_greedy_worker.sh
source "$(dirname "$0")/lib.sh"
ROGUE=${ROGUE:?ROGUE must point at rogue_worker}
write_study "$WORK/s.yaml" greedy 16 16
# A lease that expires within the test. It is also the honest worker's rollout timeout: 3 s was too
# short for two 1-s rollouts on a machine loaded by a full ctest -j2 (both killed at 3.0 s, seen once).
echo "lease_s: 6" >>"$WORK/s.yaml"
start_optimizer "$WORK/s.db"
start_worker honest --slots 2
"$ROGUE" "$DOMAIN" - - greedy 16 - 120 >"$WORK/rogue.out" 2>"$WORK/rogue.log" &
ROGUE_PID=$!; PIDS+=("$ROGUE_PID")
wait_until 30 grep -q "worker honest joined" "$WORK/optimizer.log" || fail "the honest worker never joined"
wait_until 30 grep -q "worker greedy joined" "$WORK/optimizer.log" || fail "the greedy worker never joined"
out=$(cli study submit --config "$WORK/s.yaml" --wait --json --quiet --timeout 90) || fail "the study did not complete: $out"
[[ $(json_field "$out" completed) == 16 ]] || fail "study: $out"
kill -TERM "$ROGUE_PID"; wait "$ROGUE_PID" || fail "rogue_worker exited $?"
rogue=$(cat "$WORK/rogue.out")
own=$(sed -n 's/.*own candidates \([0-9]*\);.*/\1/p' <<<"$rogue")
held=$(sed -n 's/.*lease expired \([0-9]*\)$/\1/p' <<<"$rogue")
[[ -n $own && $own -ge 3 ]] || fail "the greedy worker took fewer than 3 candidates (nothing tested): $rogue"
grep -q "worker greedy on probation" "$WORK/optimizer.log" || fail "the greedy worker was never put on probation"
[[ -n $held && $held -le 2 ]] || fail "the greedy worker held $held candidates at once after a lease expired (16 slots announced)"
[[ $(sql "$WORK/s.db" "select count(*) from trials where status='done' and worker_id='honest'") == 16 ]] ||
  fail "not every trial was run by the honest worker"
echo "PASS greedy worker: 16 slots announced, never answers; took $own candidates, at most $held at once after its" \
     "first lease expired; the study of 16 completed through the honest worker"
