#!/usr/bin/env bash
# The robot agent releases its reports the way the simulation worker does (integration.reports_released):
# once the optimizer has a report in its store it disposes the candidate, and the agent then unregisters
# that report; so a finished hardware study leaves no report in the agent's writer (instead of every
# report it ever wrote, up to 4096). A late reader of cpgmatch/reports finds none.
source "$(dirname "$0")/robot_lib.sh"
relaxed_robot_yaml "$WORK/robot.yaml"
PORT=$(free_udp_port)
write_study "$WORK/s.yaml" agent-reports-released 3 3
echo "explore_on: hardware" >>"$WORK/s.yaml"  # the agent is the only worker
start_emulator "udp:127.0.0.1:$PORT" --lockstep
start_optimizer "$WORK/s.db"
"$BIN/cpgmatch-robot-agent" --insecure --domain "$DOMAIN" --localhost-only --id morti --can "udp:127.0.0.1:$PORT" \
  --robot "$WORK/robot.yaml" --no-realtime >>"$WORK/agent.log" 2>&1 &
AGENT_PID=$!; PIDS+=("$AGENT_PID")
out=$(cli study submit --config "$WORK/s.yaml" --wait --json --quiet --timeout 90) || fail "submit --wait failed: $out"
[[ $(json_field "$out" completed) == 3 ]] || fail "completed: $out"
n=$(sql "$WORK/s.db" "select count(*) from trials where status='done' and worker_id='morti' and json_extract(report_json,'$.worker_kind')='hardware'")
[[ $n == 3 ]] || fail "expected 3 hardware reports from morti in the store, got $n"
sleep 1  # the last acknowledgement
# The agent is the only report writer on the domain; count_reports exits 1 if it does not find it.
held=$("$BIN/count_reports" "$DOMAIN") || fail "count_reports found no report writer (is the agent alive?)"
[[ $held == 0 ]] || fail "the agent still holds $held reports of a finished study (expected 0)"
kill -0 "$AGENT_PID" || fail "the agent died"
kill -TERM "$AGENT_PID"
wait "$AGENT_PID" || fail "agent exited $? after SIGTERM"
echo "PASS agent reports released: 3 counted, 0 left in the agent's writer"
