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
