#!/usr/bin/env bash
# A study served by the robot agent alone (the emulator in lockstep behind udp on loopback): the
# optimizer's candidates run through CanPlant and come back as hardware reports in the store. SIGTERM
# makes the agent leave cleanly.
source "$(dirname "$0")/robot_lib.sh"
relaxed_robot_yaml "$WORK/robot.yaml"
PORT=$(free_udp_port)
write_study "$WORK/s.yaml" hardware-only 3 3
echo "explore_on: hardware" >>"$WORK/s.yaml"  # exploration goes to simulation workers by default
start_emulator "udp:127.0.0.1:$PORT" --lockstep
start_optimizer "$WORK/s.db"
"$BIN/cpgmatch-robot-agent" --insecure --domain "$DOMAIN" --localhost-only --id morti --can "udp:127.0.0.1:$PORT" \
  --robot "$WORK/robot.yaml" --no-realtime >>"$WORK/agent.log" 2>&1 &
AGENT_PID=$!; PIDS+=("$AGENT_PID")
out=$(cli study submit --config "$WORK/s.yaml" --wait --json --quiet --timeout 90) || fail "submit --wait failed: $out"
[[ $(json_field "$out" state) == done ]] || fail "state: $out"
[[ $(json_field "$out" completed) == 3 ]] || fail "completed: $out"
n=$(sql "$WORK/s.db" "select count(*) from trials where json_extract(report_json,'$.worker_kind')='hardware' and json_extract(report_json,'$.ok') and worker_id='morti'")
[[ $n == 3 ]] || fail "expected 3 ok hardware reports from morti, got $n"
grep -q "loop .* ticks, jitter p50" "$WORK/agent.log" || fail "the agent did not log its loop statistics"
n=$(sql "$WORK/s.db" "select count(*) from trials where json_extract(report_json,'$.loop.jitter_max_us') > 0")
[[ $n == 3 ]] || fail "expected the loop jitter in all 3 stored reports, got $n"
# A study for another robot: the optimizer gives this agent none of its candidates (and the agent would
# refuse them: never measuring on the wrong body); the study waits and says why, nothing is counted.
sed -i 's/^name: .*/name: for-the-dog/' "$WORK/s.yaml"
echo "robot: odrive-quadruped" >>"$WORK/s.yaml"
id2=$(cli study submit --config "$WORK/s.yaml" --timeout 30) || fail "submit of the odrive-quadruped study failed"
waits() { [[ $(json_field "$(state_json "$id2")" message) == "waiting: robot morti is not the study's robot 'odrive-quadruped'" ]]; }
wait_until 30 waits || fail "the other robot's study does not say why it waits: $(state_json "$id2")"
[[ $(json_field "$(state_json "$id2")" completed) == 0 ]] || fail "a candidate of the other robot's study was counted"
[[ $(sql "$WORK/s.db" "select count(*) from trials where study_id=$id2 and worker_id='morti'") == 0 ]] \
  || fail "the other robot's study was issued to morti"
cli study stop "$id2" >/dev/null || true
kill -TERM "$AGENT_PID"
wait "$AGENT_PID" || fail "agent exited $? after SIGTERM"
# The study owns its robot: a study of robot morti (the spec holds morti's description) reaches an agent whose
# id is morti but whose hardware file is another robot's. The agent refuses it, the study says why, nothing counts.
sed -i 's/^robot: morti /robot: odrive-quadruped /' "$WORK/robot.yaml"
grep -q "^robot: odrive-quadruped " "$WORK/robot.yaml" || fail "the hardware file has no robot line to change"
"$BIN/cpgmatch-robot-agent" --insecure --domain "$DOMAIN" --localhost-only --id morti --can "udp:127.0.0.1:$PORT" \
  --robot "$WORK/robot.yaml" --no-realtime >>"$WORK/agent2.log" 2>&1 &
AGENT_PID=$!; PIDS+=("$AGENT_PID")
sed -i -e 's/^name: .*/name: for-morti/' -e 's/^robot: .*/robot: morti/' "$WORK/s.yaml"
id3=$(cli study submit --config "$WORK/s.yaml" --timeout 30) || fail "submit of the morti study failed"
refused() { json_field "$(state_json "$id3")" message | grep -q "worker morti refused it: the study is for robot 'morti'; this agent drives 'odrive-quadruped'"; }
wait_until 30 refused || fail "the agent of another body did not refuse the morti study with the reason: $(state_json "$id3")"
[[ $(json_field "$(state_json "$id3")" completed) == 0 ]] || fail "a refused rollout of the morti study was counted"
cli study stop "$id3" >/dev/null || true
kill -TERM "$AGENT_PID"
wait "$AGENT_PID" || fail "agent exited $? after SIGTERM"
echo "PASS hardware study: $out; a study for robot odrive-quadruped not issued to morti, waiting and saying why; one for morti refused by an agent of another body, with the reason"
