#!/usr/bin/env bash
# Study identity across stores: two optimizers with their own stores on one domain both create a study 1
# (a submit reaches both) and share one worker. Candidates and reports carry their store's id, so each
# optimizer counts only its own reports (and says once that it ignores the other's), and both studies
# finish with exactly their budget.
source "$(dirname "$0")/lib.sh"
write_study "$WORK/s.yaml" two-stores 10 10
"$BIN/cpgmatch-optimizer" --domain "$DOMAIN" --store "$WORK/a.db" --localhost-only >"$WORK/a.log" 2>&1 &
PIDS+=($!)
"$BIN/cpgmatch-optimizer" --domain "$DOMAIN" --store "$WORK/b.db" --localhost-only >"$WORK/b.log" 2>&1 &
PIDS+=($!)
start_worker w --slots 2 --fake-rollout-ms 30
# Both optimizers must know the worker before any report flows: a report is released once its candidate is
# disposed, so an optimizer that matched the worker late could miss every one of the other store's reports
# (seen once in CI: b's study was done before a had heard of the worker).
both_see_worker() { grep -q "worker w joined" "$WORK/a.log" && grep -q "worker w joined" "$WORK/b.log"; }
wait_until 30 both_see_worker || fail "the optimizers did not both see the worker"
has_a_study() { [[ $(sql "$1" "select count(*) from studies" 2>/dev/null || echo 0) -ge 1 ]]; }
both_have_a_study() { has_a_study "$WORK/a.db" && has_a_study "$WORK/b.db"; }
# A submit reaches the optimizers whose readers have matched the client: re-send until both hold a study
# (then each has its study 1, the ids that collide without store identities).
for attempt in 1 2 3 4 5 6; do
  cli study submit --config "$WORK/s.yaml" --timeout 20 >/dev/null || true
  wait_until 5 both_have_a_study && break
done
both_have_a_study || fail "the two optimizers did not both create a study"
all_done() { [[ $(sql "$1" "select count(*) from studies where state != 'done'") == 0 ]]; }
for s in a b; do
  wait_until 60 all_done "$WORK/$s.db" || fail "store $s: a study did not finish: $(sql "$WORK/$s.db" "select study_id, state from studies")"
  wrong=$(sql "$WORK/$s.db" "select study_id from trials where status = 'done' group by study_id having count(*) != 10")
  [[ -z $wrong ]] || fail "store $s: studies without exactly 10 results: $wrong"
  grep -q "ignoring reports for another store" "$WORK/$s.log" || fail "optimizer $s did not see (and ignore) the other store's reports"
done
echo "PASS two stores on one domain: every study counted exactly its own 10 reports"
