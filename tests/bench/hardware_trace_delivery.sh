#!/usr/bin/env bash
# By hand (docs/robot_agent.md, "Rollout traces"): one hardware study of two 20 s rollouts (10 s + 10 s, the
# paper's length) on the agent and the emulator in lockstep, and what their traces cost: ticks, bytes in the
# store, the agent's send-to-acknowledged time. BIN=build/bin DOMAIN=88 bash tests/bench/hardware_trace_delivery.sh
source "$(dirname "$0")/../robot/robot_lib.sh"
relaxed_robot_yaml "$WORK/robot.yaml"
PORT=$(free_udp_port)
write_study "$WORK/s.yaml" long 2 2
sed -i 's/^rollout: .*/rollout: {entrain_s: 10.0, eval_s: 10.0}/' "$WORK/s.yaml"
cat >>"$WORK/s.yaml" <<'YAML'
explore_on: hardware
base_parameters: {hip_offset: -0.1934, duty_factor_front: 0.3, duty_factor_hind: 0.75, knee_phase_shift: 0.0, overswing: 0.5}
parameters:
  - {name: hip_amplitude, low: 0.30, high: 0.40}
YAML
start_emulator "udp:127.0.0.1:$PORT" --lockstep --model "$CONFIGS/model/worn-knee-spring.yaml"
start_optimizer "$WORK/s.db"
"$BIN/cpgmatch-robot-agent" --insecure --domain "$DOMAIN" --localhost-only --id morti --can "udp:127.0.0.1:$PORT" \
  --robot "$WORK/robot.yaml" --no-realtime --lockstep >>"$WORK/agent.log" 2>&1 &
PIDS+=($!)
out=$(cli study submit --config "$WORK/s.yaml" --wait --json --quiet --timeout 120)
sleep 3
grep -h "trace\|cost" "$WORK/agent.log" "$WORK/optimizer.log"
sql "$WORK/s.db" "select trial_id, tick_count, length(ticks), received_at from traces"
sql "$WORK/s.db" "select trial_id, reported_at from trials"
ls -la "$WORK/s.db"*
