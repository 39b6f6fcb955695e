#!/usr/bin/env bash
# Synthetic rollouts are marked end to end and never drawn (issue 32). A study runs 6 trials on a worker
# with --fake-rollout-ms (a service benchmark's synthetic cost, no gait), then is extended by 4 trials run by
# a real simulation worker. Asserted: the store's reports of exactly the 6 fake trials say "synthetic": true
# (the mark crossed the wire), the CSV, JSON and Optuna exports mark the same 6 and only them, `plot` exits 0,
# its figure data (fig5.dat) has exactly the 4 real rollouts and it says it left 6 out, and `analyze --json`
# counts 4 rollouts and 6 synthetic ones left out.
source "$(dirname "$0")/lib.sh"
write_study "$WORK/s.yaml" synthetic-marked 6 4
start_optimizer "$WORK/s.db"
start_worker fake --slots 2 --fake-rollout-ms 20
fake_pid=$WORKER_PID
id=$(cli study submit --config "$WORK/s.yaml" --timeout 20) || fail "submit failed"
wait_until 60 study_is "$id" done || fail "the fake part did not finish: $(state_json "$id")"
kill "$fake_pid"
wait "$fake_pid" 2>/dev/null
start_worker real --slots 1
cli study extend "$id" --budget 4 --timeout 20 >/dev/null || fail "extend failed"
wait_until 120 study_is "$id" done || fail "the real part did not finish: $(state_json "$id")"

db="$WORK/s.db"
marked=$(sql "$db" "SELECT group_concat(trial_id) FROM trials WHERE study_id = $id AND json_extract(report_json, '\$.synthetic') = 1")
real=$(sql "$db" "SELECT count(*) FROM trials WHERE study_id = $id AND ok = 1 AND json_extract(report_json, '\$.synthetic') IS NULL")
[[ $marked == "0,1,2,3,4,5" && $real -eq 4 ]] || fail "store: synthetic trials '$marked', unmarked real ones $real (want 0-5 and 4)"

"$BIN/cpgmatch" export --store "$db" --study "$id" --format csv --out "$WORK/t.csv" 2>/dev/null || fail "csv export exited $?"
csv=$(python3 - "$WORK/t.csv" <<'PY'
import csv, sys
rows = list(csv.DictReader(open(sys.argv[1])))
print(",".join(r["trial_id"] for r in rows if r["synthetic"] == "true"), sum(r["synthetic"] == "false" for r in rows))
PY
)
[[ $csv == "0,1,2,3,4,5 4" ]] || fail "csv export marks '$csv' (want '0,1,2,3,4,5 4')"
"$BIN/cpgmatch" export --store "$db" --study "$id" --format json --out "$WORK/t.json" 2>/dev/null || fail "json export exited $?"
json=$(python3 -c 'import json,sys; t=json.load(open(sys.argv[1]))["studies"][0]["trials"]; print(",".join(str(r["trial_id"]) for r in t if r["synthetic"] is True), sum(r["synthetic"] is False for r in t))' "$WORK/t.json")
[[ $json == "0,1,2,3,4,5 4" ]] || fail "json export marks '$json'"
"$BIN/cpgmatch" export --store "$db" --study "$id" --format optuna-journal --out "$WORK/t.log" 2>/dev/null || fail "optuna export exited $?"
optuna=$(grep -c '"synthetic":true' "$WORK/t.log")
[[ $optuna -eq 6 ]] || fail "optuna journal marks $optuna trials synthetic (want 6)"

"$BIN/cpgmatch" plot --store "$db" --study "$id" --out "$WORK/figs" >"$WORK/plot.out" 2>"$WORK/plot.err" ||
  fail "plot exited $?: $(cat "$WORK/plot.err")"
grep -q "not drawn: every figure: 6 synthetic rollouts (--fake-rollout-ms, no gait) left out" "$WORK/plot.err" ||
  fail "plot did not say what it left out: $(cat "$WORK/plot.err")"
drawn=$(grep -v '^#' "$WORK/figs/fig5.dat" | awk '{print $1}' | paste -sd, -)
[[ $drawn == "7,8,9,10" ]] || fail "fig5.dat draws rollouts '$drawn' (want only the real 7,8,9,10)"
[[ -s $WORK/figs/fig5a.png ]] || fail "fig5a was not drawn from the real rollouts"

"$BIN/cpgmatch" analyze --store "$db" --study "$id" --jitter 0 --json >"$WORK/a.json" 2>/dev/null || fail "analyze exited $?"
counts=$(python3 -c 'import json,sys; a=json.load(open(sys.argv[1])); print(a["rollouts"], a["synthetic_left_out"])' "$WORK/a.json")
[[ $counts == "4 6" ]] || fail "analyze counts '$counts' (want 4 rollouts, 6 synthetic left out)"
echo "PASS synthetic rollouts marked in the store and csv/json/optuna exports (trials 0-5), left out of fig5.dat and analyze (6 counted)"
