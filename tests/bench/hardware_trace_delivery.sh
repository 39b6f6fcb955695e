#!/usr/bin/env bash
# By hand (docs/robot_agent.md, "Rollout traces"): one hardware study of two 20 s rollouts (10 s + 10 s, the
# paper's length) on the agent and the emulator in lockstep, and what their traces cost: ticks, bytes in the
# store, the agent's send-to-acknowledged time. BIN=build/bin DOMAIN=88 bash tests/bench/hardware_trace_delivery.sh
source "$(dirname "$0")/../robot/robot_lib.sh"
relaxed_robot_yaml "$WORK/robot.yaml"
matched_trot_hardware_study "$WORK/s.yaml" long 2 10.0 10.0
start_optimizer "$WORK/s.db"
start_lockstep_robot "$CONFIGS/model/worn-knee-spring.yaml"
out=$(cli study submit --config "$WORK/s.yaml" --wait --json --quiet --timeout 120)
sleep 3
grep -h "trace\|cost" "$WORK/agent.log" "$WORK/optimizer.log"
sql "$WORK/s.db" "select trial_id, tick_count, length(ticks), received_at from traces"
sql "$WORK/s.db" "select trial_id, reported_at from trials"
ls -la "$WORK/s.db"*
