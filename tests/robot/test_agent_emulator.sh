#!/usr/bin/env bash
# The agent against the CAN-level twin over udp: on loopback, without DDS (--run-once): bad input, the
# safe envelope, the direct simulation reproduced in lockstep, the emulator killed mid-rollout, SIGTERM.
source "$(dirname "$0")/robot_lib.sh"
relaxed_robot_yaml "$WORK/robot.yaml"
AGENT="$BIN/cpgmatch-robot-agent"

# Bad input: exit 2 naming the part; a bus that cannot open: exit 1 with the reason.
set +e
out=$("$AGENT" --can tcp:1.2.3.4:5 --run-once 2>&1); rc=$?
set -e
[[ $rc == 2 && $out == *"unknown scheme 'tcp'"* ]] || fail "bad scheme: rc $rc: $out"
set +e
out=$("$AGENT" --can udp:127.0.0.1:99999 --run-once 2>&1); rc=$?
set -e
[[ $rc == 2 && $out == *"port '99999' must be a number in 1..65535"* ]] || fail "bad port: rc $rc: $out"
sed 's/FL_knee: {leg: FL, /FL_knee: {/' "$CONFIGS/robot/morti.yaml" >"$WORK/no-leg.yaml"
set +e
out=$("$AGENT" --can udp:127.0.0.1:1 --robot "$WORK/no-leg.yaml" --run-once 2>&1); rc=$?
set -e
[[ $rc == 2 && $out == *"no-leg.yaml:"*"field 'joints.FL_knee.leg': is missing"* ]] || fail "joint without a leg: rc $rc: $out"
set +e
out=$("$AGENT" --can socketcan:can0 --run-once 2>&1); rc=$?
set -e
[[ $rc == 1 && ( $out == *"socketcan:can0: this kernel has no SocketCAN (AF_CAN)"* || $out == *"socketcan:can0: no network interface"* ) ]] \
  || fail "socketcan: rc $rc: $out"
set +e
out=$("$AGENT" --can socketcan:can0 --robot "$WORK/robot.yaml" --run-once 2>&1); rc=$?
set -e
[[ $rc == 2 && $out == *"emulator_only: true may not drive socketcan:can0"* ]] || fail "emulator_only on socketcan: rc $rc: $out"

# A candidate outside the robot's safe envelope is refused before any motor moves.
PORT=$(free_udp_port)
printf 'hip_amplitude: 0.69\n' >"$WORK/wide.yaml"
set +e
out=$("$AGENT" --can "udp:127.0.0.1:$PORT" --robot "$WORK/robot.yaml" --run-once --params "$WORK/wide.yaml" --json 2>"$WORK/refused.log"); rc=$?
set -e
[[ $rc == 2 ]] || fail "out-of-envelope candidate: rc $rc: $out"
[[ $(json_field "$out" error) == "refused: hip_amplitude = 0.69 is outside the robot's safe envelope [0.05, 0.65]"* ]] || fail "refusal: $out"

# Lockstep: the agent reproduces the direct simulation of the same parameters and seed.
start_emulator "udp:127.0.0.1:$PORT" --lockstep
agent=$("$AGENT" --can "udp:127.0.0.1:$PORT" --robot "$WORK/robot.yaml" --no-realtime --lockstep --run-once \
        --params "$CONFIGS/params/matched-trot.yaml" --entrain 4 --eval 4 --seed 5 --json 2>>"$WORK/agent.log") \
  || fail "agent rollout failed: $agent"
sim=$("$BIN/cpgmatch" rollout --params "$CONFIGS/params/matched-trot.yaml" --entrain 4 --eval 4 --seed 5 --json) \
  || fail "direct rollout failed"
python3 - "$agent" "$sim" <<'PY' || fail "the agent does not reproduce the direct simulation"
import json, sys
agent, sim = json.loads(sys.argv[1]), json.loads(sys.argv[2])
print("agent:", {k: agent[k] for k in ("cost", "fell", "distance_m", "normalized_torque")}, "loop:", agent["loop"])
print("sim:  ", {k: sim[k] for k in ("cost", "fell", "distance_m")}, "terms:", sim["terms"])
assert agent["ok"], agent["error"]
assert agent["fell"] == sim["fell"]
# Tolerance (docs/robot_agent.md): the bus quantises positions (0.4 mrad), torques (9 mN m) and forces
# (0.01 N). Continuous quantities stay within 7 %. J_contact counts discrete contact changes: a marginal
# landing that touches and lifts once more in the 4 steps evaluated moves it by 2 / (2 x 4 legs x 4 steps),
# so the twin may differ by that one event; the cost without J_contact stays within 7 %.
one_touch_and_lift = 2.0 / (2 * 4 * 4)
assert abs(agent["terms"]["contact"] - sim["terms"]["contact"]) <= one_touch_and_lift + 1e-9, (agent["terms"], sim["terms"])
rest = lambda r: r["cost"] - r["terms"]["contact"]
assert abs(rest(agent) - rest(sim)) <= 0.07 * rest(sim), (rest(agent), rest(sim))
assert abs(agent["distance_m"] - sim["distance_m"]) <= 0.07 * abs(sim["distance_m"])
assert agent["loop"]["ticks"] == 4000
PY
kill -TERM "$EMU_PID"; wait "$EMU_PID" || fail "emulator exited $? after SIGTERM"

# Real time, then the emulator dies mid-rollout: a safe stop with the reason, never a hang.
PORT=$(free_udp_port)
start_emulator "udp:127.0.0.1:$PORT"
"$AGENT" --can "udp:127.0.0.1:$PORT" --robot "$WORK/robot.yaml" --run-once --params "$CONFIGS/params/matched-trot.yaml" \
  --entrain 20 --eval 5 --json >"$WORK/killed.json" 2>>"$WORK/agent.log" &
AGENT_PID=$!; PIDS+=("$AGENT_PID")
sleep 2
kill -9 "$EMU_PID"
set +e
timeout 10 tail --pid="$AGENT_PID" -f /dev/null; wait "$AGENT_PID"; rc=$?
set -e
out=$(cat "$WORK/killed.json")
[[ $rc == 1 ]] || fail "agent after the emulator died: rc $rc: $out"
[[ $(json_field "$out" error) == "safe stop at t = "*"silent for"* ]] || fail "no safe stop reason: $out"

# SIGTERM mid-rollout: the rollout stops safely at once and says why.
PORT=$(free_udp_port)
start_emulator "udp:127.0.0.1:$PORT"
"$AGENT" --can "udp:127.0.0.1:$PORT" --robot "$WORK/robot.yaml" --run-once --entrain 20 --eval 5 --json \
  >"$WORK/term.json" 2>>"$WORK/agent.log" &
AGENT_PID=$!; PIDS+=("$AGENT_PID")
sleep 2
kill -TERM "$AGENT_PID"
set +e
timeout 10 tail --pid="$AGENT_PID" -f /dev/null; wait "$AGENT_PID"; rc=$?
set -e
out=$(cat "$WORK/term.json")
[[ $rc == 1 && $(json_field "$out" error) == *"emergency stop: SIGINT/SIGTERM"* ]] || fail "SIGTERM: rc $rc: $out"
# The motor drivers' own watchdog: the agent killed (-9) mid-rollout sends nothing more, not even the safe
# state; the emulator's drivers put every motor in the safe state by themselves within their timeout.
PORT=$(free_udp_port)
"$BIN/cpgmatch-robot-emulator" --can "udp:127.0.0.1:$PORT" --driver-timeout-ms 100 >"$WORK/drivers.log" 2>&1 &
PIDS+=("$!")
sleep 0.3
"$AGENT" --can "udp:127.0.0.1:$PORT" --robot "$WORK/robot.yaml" --run-once --entrain 20 --eval 5 --json \
  >/dev/null 2>>"$WORK/agent.log" &
AGENT_PID=$!; PIDS+=("$AGENT_PID")
wait_until 20 grep -q "rollout 1 starts" "$WORK/drivers.log" || fail "the rollout did not start"
sleep 2
since_kill() { grep -q "$1" "$WORK/drivers.log"; }
since_kill "every motor safe" && fail "motors safe before the agent died"
killed_at=$(python3 -c 'import time; print(time.time())')
kill -9 "$AGENT_PID"
wait_until 5 since_kill "driver watchdog" || fail "the drivers did not notice the silent controller: $(tail -3 "$WORK/drivers.log")"
wait_until 5 since_kill "every motor safe" || fail "the motors were not made safe after the controller died"
ms=$(python3 - "$killed_at" "$WORK/drivers.log" <<'PY'
import re, sys
killed = float(sys.argv[1])
for line in open(sys.argv[2]):
    m = re.search(r"driver watchdog: .* at unix ([0-9.]+) s", line)
    if m and float(m.group(1)) >= killed:
        print(f"{(float(m.group(1)) - killed) * 1000:.0f}")
        break
PY
)
[[ -n $ms ]] || fail "no driver watchdog line after the kill"
# 100 ms timeout plus at most one physics step; this shared machine may stall a process ~100 ms.
python3 -c "import sys; sys.exit(0 if $ms <= 400 else 1)" || fail "the drivers took $ms ms to make the motors safe"
echo "PASS agent and emulator (drivers' own watchdog: motors safe $ms ms after the controller was killed)"
