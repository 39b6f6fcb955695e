#!/usr/bin/env bash
# A mixed study over real DDS on loopback (issue 10): the exploration on a simulation worker (real
# rollouts of 1 s: synthetic ones, --fake-rollout-ms, are left out of sim2real since issue 32), then the validation sets on the robot agent against the emulator in lockstep. Until the agent
# joins, the validation phase waits and says so in the study state; `study submit --wait` returns when both
# phases are done; the store holds the hardware reports with phase 'validation'; `cpgmatch sim2real` tables them.
source "$(dirname "$0")/robot_lib.sh"
relaxed_robot_yaml "$WORK/robot.yaml"
PORT=$(free_udp_port)
write_study "$WORK/s.yaml" mixed 6 3
echo "validation: {hardware_sets: 2, spread: 0.10}" >>"$WORK/s.yaml"
start_emulator "udp:127.0.0.1:$PORT" --lockstep
start_optimizer "$WORK/s.db"
start_worker sim1
cli study submit --config "$WORK/s.yaml" --wait --json --quiet --timeout 30 >"$WORK/submit.out" &
SUBMIT_PID=$!
PIDS+=("$SUBMIT_PID")
# No hardware worker yet: the exploration finishes, the validation waits and says so.
waiting() { [[ $(json_field "$(state_json 1)" message) == waiting_for_hardware* ]]; }
wait_until 60 waiting || fail "the validation phase did not say it waits for hardware: $(state_json 1)"
st=$(state_json 1)
[[ $(json_field "$st" state) == running ]] || fail "waiting study is not running: $st"
[[ $(json_field "$st" completed) == 6 ]] || fail "exploration not complete while waiting: $st"
n=$(sql "$WORK/s.db" "select count(*) from trials where phase='validation' and status='in_flight'")
[[ $n == 2 ]] || fail "expected 2 stored validation sets waiting, got $n"
"$BIN/cpgmatch-robot-agent" --insecure --domain "$DOMAIN" --localhost-only --id morti --can "udp:127.0.0.1:$PORT" \
  --robot "$WORK/robot.yaml" --no-realtime >>"$WORK/agent.log" 2>&1 &
AGENT_PID=$!; PIDS+=("$AGENT_PID")
sleep 1
kill -0 "$AGENT_PID" 2>/dev/null || fail "the robot agent did not start"
submit_done() { ! kill -0 "$SUBMIT_PID" 2>/dev/null; }
wait_until 150 submit_done || fail "submit --wait did not return after both phases: $(state_json 1)"
wait "$SUBMIT_PID" || fail "submit --wait failed: $(cat "$WORK/submit.out")"
out=$(cat "$WORK/submit.out")
[[ $(json_field "$out" state) == done ]] || fail "state: $out"
[[ $(json_field "$out" completed) == 8 ]] || fail "completed (6 + 2): $out"
n=$(sql "$WORK/s.db" "select count(*) from trials where phase='exploration' and worker_id='sim1' and json_extract(report_json,'$.worker_kind')='sim'")
[[ $n == 6 ]] || fail "expected 6 exploration rollouts on sim1, got $n"
n=$(sql "$WORK/s.db" "select count(*) from trials where phase='validation' and worker_id='morti' and json_extract(report_json,'$.worker_kind')='hardware' and json_extract(report_json,'$.ok')")
[[ $n == 2 ]] || fail "expected 2 ok hardware validation reports from morti, got $n"
table=$("$BIN/cpgmatch" sim2real --store "$WORK/s.db" --json --plot "$WORK/fig") || fail "sim2real failed"
[[ $(json_field "$table" hardware_rollouts) == 2 ]] || fail "sim2real: $table"
[[ $(json_field "$table" simulation_rollouts) == 6 ]] || fail "sim2real: $table"
[[ -s $WORK/fig/sim2real.png && -s $WORK/fig/sim2real.svg ]] || fail "no sim2real figure"
text=$("$BIN/cpgmatch" sim2real --store "$WORK/s.db") || fail "sim2real text exited $?"
grep -q "J_distance" <<<"$text" || fail "sim2real text has no J_distance row: $text"
set +e
"$BIN/cpgmatch" sim2real --store "$WORK/missing.db" 2>"$WORK/err.txt"; rc=$?
set -e
[[ $rc == 2 ]] && grep -q -- "--store" "$WORK/err.txt" || fail "sim2real on a missing store: exit $rc, $(cat "$WORK/err.txt")"
# Captured, not piped into grep -q: with pipefail, grep leaving at the first match can SIGPIPE the writer.
report=$("$BIN/cpgmatch" analyze --store "$WORK/s.db" --jitter 0 2>"$WORK/analyze.err") || fail "analyze exited $?: $(cat "$WORK/analyze.err")"
grep -q "Simulation vs hardware" <<<"$report" || fail "no sim2real section in the report: $report"
kill -TERM "$AGENT_PID"
wait "$AGENT_PID" || fail "agent exited $? after SIGTERM"
echo "PASS mixed study: $out"
