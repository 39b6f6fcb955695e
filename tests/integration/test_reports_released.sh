#!/usr/bin/env bash
# Bounded histories: once the optimizer has a report in its store it disposes the candidate, and the
# worker then unregisters its report; so a finished study leaves no reports in the worker's writer (nor
# instances in the optimizer's reader), instead of the last 4096 per worker. A late reader finds none.
source "$(dirname "$0")/lib.sh"
write_study "$WORK/s.yaml" reports-released 24
start_optimizer "$WORK/s.db"
start_worker w --slots 4 --fake-rollout-ms 20
id=$(cli study submit --config "$WORK/s.yaml" --timeout 20) || fail "submit failed"
wait_until 60 study_is "$id" done || fail "the study did not finish"
sleep 1  # the last acknowledgements
held=$("$BIN/count_reports" "$DOMAIN") || fail "count_reports found no report writer"
[[ $held == 0 ]] || fail "the worker still holds $held reports of a finished study (expected 0)"
[[ $(sql "$WORK/s.db" "select count(*) from trials where status='done'") == 24 ]] || fail "store: not 24 done trials"
echo "PASS reports released: 24 counted, 0 left in the worker's writer"
