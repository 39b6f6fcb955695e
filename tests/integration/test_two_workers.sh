#!/usr/bin/env bash
# Two simulation workers (real ODE rollouts) finish a small study; both did work; SIGTERM exits 0 and the
# optimizer logs each as leaving cleanly, not as silent or lost.
source "$(dirname "$0")/lib.sh"
write_study "$WORK/s.yaml" two-workers 12 6
start_optimizer "$WORK/s.db"
start_worker a --slots 1; A=$WORKER_PID
start_worker b --slots 1; B=$WORKER_PID
out=$(cli study submit --config "$WORK/s.yaml" --wait --json --quiet --timeout 20) || fail "submit --wait failed"
[[ $(json_field "$out" state) == done ]] || fail "state: $out"
[[ $(json_field "$out" completed) == 12 ]] || fail "completed: $out"
[[ $(json_field "$out" budget) == 12 ]] || fail "budget: $out"
[[ -n $(json_field "$out" best_cost) ]] || fail "no best cost: $out"
[[ $(sql "$WORK/s.db" "select count(*) from trials where status='done'") == 12 ]] || fail "store does not hold 12 done trials"
[[ $(sql "$WORK/s.db" "select count(distinct worker_id) from trials") == 2 ]] || fail "both workers should have run rollouts"
[[ $(sql "$WORK/s.db" "select count(*) from trials where json_extract(report_json,'$.worker_kind')='sim' and json_extract(report_json,'$.ok')") == 12 ]] || fail "reports are not ok sim reports"
kill -TERM "$A" "$B"
wait "$A" || fail "worker a exited $? after SIGTERM"
wait "$B" || fail "worker b exited $? after SIGTERM"
for id in a b; do
  wait_until 5 grep -q "worker $id left: it shut down cleanly" "$WORK/optimizer.log" ||
    fail "the optimizer did not log worker $id's clean shutdown as a leave: $(grep "worker $id " "$WORK/optimizer.log" | tail -2)"
done
! grep -E "worker (a|b) (silent|lost)" "$WORK/optimizer.log" || fail "a clean shutdown was logged as silent or lost"
echo "PASS two workers: $out"
