#!/usr/bin/env bash
# Issue 34: `status --json` and the dashboard list the same studies in the same states at the same moment:
# during a study, right after it finished, after one was refused, and after the optimizer was killed and
# restarted on a store where one study's stored spec no longer loads (the old dashboard still showed such a
# study "running"; `status` left it out). A refused submit leaves nothing behind.
source "$(dirname "$0")/lib.sh"

"$BIN/cpgmatch" dashboard --port 0 --domain "$DOMAIN" --localhost-only >"$WORK/dashboard.out" 2>"$WORK/dashboard.log" &
PIDS+=($!)
wait_until 10 grep -q "http://" "$WORK/dashboard.out" || fail "the dashboard printed no URL"
url=$(grep -o 'http://[^ ]*' "$WORK/dashboard.out")

start_optimizer "$WORK/s.db"
start_worker w1 --fake-rollout-ms 100 --slots 2

# "id state" lines, sorted, from each side.
from_status() {
  cli status --json --timeout 5 2>/dev/null |
    python3 -c 'import json,sys; [print(s["study_id"], s["state"]) for s in sorted(json.load(sys.stdin), key=lambda s: s["study_id"])]'
}
from_dashboard() {
  curl -s -m 3 "${url}api/snapshot" |
    python3 -c 'import json,sys; d=json.load(sys.stdin); [print(s["state"]["study_id"], s["state"]["state"]) for s in sorted(d["studies"], key=lambda s: s["state"]["study_id"])]'
}
# The same moment: status, dashboard, status again; a study that changed state in between is read again.
agree() {  # agree WHAT: both sides list the same studies in the same states
  local a b c tries
  for tries in 1 2 3 4 5 6 7 8 9 10; do
    a=$(from_status); b=$(from_dashboard); c=$(from_status)
    if [[ $a == "$c" && $a == "$b" ]]; then
      echo "PASS $1: status and dashboard agree: $(echo "$a" | tr '\n' ',')"
      return 0
    fi
    sleep 0.5
  done
  fail "$1: status says [$(echo "$a" | tr '\n' ',')], the dashboard [$(echo "$b" | tr '\n' ',')]"
}

write_study "$WORK/a.yaml" first 200 6
write_study "$WORK/b.yaml" second 12 4
id_a=$(cli study submit --config "$WORK/a.yaml" --timeout 20) || fail "submit a"
id_b=$(cli study submit --config "$WORK/b.yaml" --timeout 20) || fail "submit b"
wait_until 30 completed_at_least "$id_a" 3 || fail "study a did not start"
agree "during two studies"
[[ $(from_status) == *running* ]] || fail "not during: no study was running any more ($(from_status | tr '\n' ','))"
wait_until 60 study_is "$id_b" done || fail "study b did not finish"
agree "right after study $id_b finished"

# A refused study (constraints that leave nothing feasible): exit 2 naming file:line, nothing stored or shown.
cat >"$WORK/bad.yaml" <<YAML
name: infeasible
budget: 30
constraints:
  - "hip_offset >= 100"
YAML
before=$(sql "$WORK/s.db" "select count(*) from studies")
rc=0
"$BIN/cpgmatch" study submit --config "$WORK/bad.yaml" --domain "$DOMAIN" --localhost-only --timeout 20 >/dev/null \
  2>"$WORK/bad.err" || rc=$?
((rc == 2)) || fail "the infeasible study exited $rc, not 2: $(cat "$WORK/bad.err")"
grep -q "bad.yaml:4" "$WORK/bad.err" || fail "the refusal names no file:line: $(cat "$WORK/bad.err")"
[[ $(sql "$WORK/s.db" "select count(*) from studies") == "$before" ]] || fail "the refused study was stored"
agree "after a refused submit"
echo "PASS refused submit: exit 2, '$(head -c 140 "$WORK/bad.err")', store still $before studies"

# Restart: study a's stored spec damaged; the restarted optimizer cannot serve it and says so, failed.
wait_until 90 study_is "$id_a" done || fail "study a did not finish"
kill -9 "$OPT_PID"
wait "$OPT_PID" 2>/dev/null || true
sql "$WORK/s.db" "update studies set state = 'running', spec_json = '{\"broken' where study_id = $id_a"
start_optimizer "$WORK/s.db"
study_failed() { [[ $(from_status | grep "^$id_a ") == "$id_a failed" ]]; }
wait_until 30 study_failed || fail "after the restart study $id_a is not listed as failed: $(from_status | tr '\n' ',')"
agree "after a restart with a study that cannot be served"
