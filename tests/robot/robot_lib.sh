# Helpers for the robot agent's process tests (on top of tests/integration/lib.sh).
source "$(dirname "$0")/../integration/lib.sh"
CONFIGS="$(cd "$(dirname "$0")/../../configs" && pwd)"

# The shipped Morti description marked emulator_only with a slow watchdog: this machine is shared, and a
# loop descheduled for 12 ms would (rightly) be a safe stop on the robot. Tests of the watchdog's timing
# use the shipped file.
relaxed_robot_yaml() {  # relaxed_robot_yaml FILE
  sed -e 's/^protocol: mit/emulator_only: true\nprotocol: mit/' \
      -e 's/feedback_timeout_s: 0.010/feedback_timeout_s: 0.5/' \
      -e 's/max_consecutive_overruns: 5 /max_consecutive_overruns: 100 /' "$CONFIGS/robot/morti.yaml" >"$1"
}

start_emulator() {  # start_emulator URI [extra args]; sets EMU_PID
  local uri=$1; shift
  "$BIN/cpgmatch-robot-emulator" --can "$uri" "$@" >>"$WORK/emulator.log" 2>&1 &
  EMU_PID=$!
  PIDS+=("$EMU_PID")
  sleep 0.3
}

# A hardware-only study around the matched trot (configs/params/matched-trot.yaml; only the hip amplitude
# varies), so that the robot walks rather than falls at once: the rollout traces' tests and benchmark.
matched_trot_hardware_study() {  # matched_trot_hardware_study FILE NAME BUDGET ENTRAIN_S EVAL_S
  write_study "$1" "$2" "$3" "$3"
  sed -i "s/^rollout: .*/rollout: {entrain_s: $4, eval_s: $5}/" "$1"
  cat >>"$1" <<'YAML'
explore_on: hardware
base_parameters: {hip_offset: -0.1934, duty_factor_front: 0.3, duty_factor_hind: 0.75, knee_phase_shift: 0.0, overswing: 0.5}
parameters:
  - {name: hip_amplitude, low: 0.30, high: 0.40}
YAML
}

# The emulator in lockstep on MODEL and the agent (id morti) on it; sets AGENT_PID.
start_lockstep_robot() {  # start_lockstep_robot MODEL.yaml
  local port
  port=$(free_udp_port)
  start_emulator "udp:127.0.0.1:$port" --lockstep --model "$1"
  "$BIN/cpgmatch-robot-agent" --insecure --domain "$DOMAIN" --localhost-only --id morti --can "udp:127.0.0.1:$port" \
    --robot "$WORK/robot.yaml" --no-realtime --lockstep >>"$WORK/agent.log" 2>&1 &
  AGENT_PID=$!
  PIDS+=("$AGENT_PID")
}
