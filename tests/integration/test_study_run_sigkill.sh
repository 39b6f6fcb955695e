#!/usr/bin/env bash
# `cpgmatch study run` SIGKILLed mid-study: its optimizer and workers (and their rollout processes) die
# with it instead of running on as orphans.
source "$(dirname "$0")/lib.sh"
write_study "$WORK/s.yaml" sigkill-study 200 200
"$BIN/cpgmatch" study run --config "$WORK/s.yaml" --workers 2 --out "$WORK/run" --domain "$DOMAIN" --quiet \
  --jitter 0 >"$WORK/run.log" 2>&1 &
RUN_PID=$!
PIDS+=("$RUN_PID")
# "[-]-domain": a pattern that does not match the command lines of this script's own helpers.
ours() { pgrep -f -- "[-]-domain $DOMAIN " | grep -vx "$RUN_PID" | wc -l; }
done_trials() { sql "$WORK/run/study.db" "select count(*) from trials where status='done'" 2>/dev/null || echo 0; }
running() { [[ -f $WORK/run/study.db ]] && (($(done_trials) >= 2)); }
wait_until 60 running || fail "study run did not get going"
children=$(ours)
((children >= 3)) || fail "expected the optimizer and two workers, found $children processes"
kill -9 "$RUN_PID"
none_left() { (($(ours) == 0)); }
wait_until 10 none_left || fail "$(ours) processes of the killed study run are still alive: $(pgrep -af -- "[-]-domain $DOMAIN ")"
echo "PASS study run SIGKILL: $children child processes before the kill, none after"
