#!/usr/bin/env bash
# Benchmark (by hand): the agent's 500 Hz loop against the real-time emulator over udp on loopback.
# Prints the loop's wake-up jitter p50/p99/max, overruns, command-to-feedback latency (sending the
# period's commands until the last motor's reply), and the CPU share of the agent and the emulator.
#   tests/bench/robot_loop.sh build [SECONDS] [ROBOT.yaml]
set -euo pipefail
BUILD=${1:?usage: robot_loop.sh BUILD_DIR [SECONDS] [ROBOT.yaml]}
SECONDS_RUN=${2:-20}
ROOT="$(cd "$(dirname "$0")/../.." && pwd)"
ROBOT=${3:-$ROOT/configs/robot/morti.yaml}
BIN="$BUILD/bin"
PORT=$(python3 -c 'import socket; s=socket.socket(socket.AF_INET, socket.SOCK_DGRAM); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')
"$BIN/cpgmatch-robot-emulator" --can "udp:127.0.0.1:$PORT" --robot "$ROBOT" 2>/dev/null &
EMU=$!
trap 'kill $EMU 2>/dev/null || true' EXIT
sleep 0.5
half=$(python3 -c "print($SECONDS_RUN / 2)")
/usr/bin/time -f '%U %S %e' -o /tmp/robot_loop_time.$$ "$BIN/cpgmatch-robot-agent" --can "udp:127.0.0.1:$PORT" \
  --robot "$ROBOT" --run-once --params "$ROOT/configs/params/matched-trot.yaml" --entrain "$half" --eval "$half" --json \
  >/tmp/robot_loop_out.$$ 2>/tmp/robot_loop_err.$$ || true
if [[ ! -s /tmp/robot_loop_out.$$ ]]; then
  echo "the agent printed no report:"; cat /tmp/robot_loop_err.$$ /tmp/robot_loop_time.$$; exit 1
fi
ticks_per_s=$(getconf CLK_TCK)
read -r _ _ _ _ _ _ _ _ _ _ _ utime stime _ < <(cut -d')' -f2 /proc/$EMU/stat)
python3 - "$(cat /tmp/robot_loop_out.$$)" "$(grep -E '^[0-9.]+ [0-9.]+ [0-9.:]+$' /tmp/robot_loop_time.$$ | tail -n 1)" "$utime" "$stime" "$ticks_per_s" <<'PY'
import json, sys
report = json.loads(sys.argv[1])
user, system, wall = map(float, sys.argv[2].split())
emu_cpu = (int(sys.argv[3]) + int(sys.argv[4])) / int(sys.argv[5])
loop = report["loop"]
print(f"rollout: ok={report['ok']} {report['error'] or ''} cost={report['cost']} ticks={loop['ticks']}")
print(f"loop jitter (wake-up lateness): p50 {loop['jitter_p50_us']:.0f} us, p99 {loop['jitter_p99_us']:.0f} us, "
      f"max {loop['jitter_max_us']:.0f} us; overruns {loop['overruns']}; missing replies {loop['missing_replies']}")
print(f"command to last motor reply: p50 {loop['feedback_latency_p50_us']:.0f} us, p99 {loop['feedback_latency_p99_us']:.0f} us, "
      f"max {loop['feedback_latency_max_us']:.0f} us")
print(f"agent CPU: {user + system:.2f} s in {wall:.2f} s wall ({100 * (user + system) / wall:.1f} %), rollout thread {loop['cpu_s']:.2f} s")
print(f"emulator CPU: {emu_cpu:.2f} s (over its life, about {wall + 0.5:.1f} s)")
PY
grep -i "warn" /tmp/robot_loop_err.$$ || true
rm -f /tmp/robot_loop_out.$$ /tmp/robot_loop_err.$$ /tmp/robot_loop_time.$$
