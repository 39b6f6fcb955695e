#!/usr/bin/env bash
# `cmake --install` into a temporary prefix, then use the installed programs the way a user would: from
# another folder, with nothing pointing at the source tree. Proves the installed binaries find their
# configs and Fast DDS profiles under <prefix>/share/cpgmatch (also after moving the prefix), print their
# version, and run a rollout, a tiny study and a rollout of the robot agent against the emulator; units and
# man pages are where Debian expects them.
#   test_install.sh BUILD_DIR
set -euo pipefail
BUILD=${1:?usage: test_install.sh BUILD_DIR}
WORK=$(mktemp -d "${TMPDIR:-/tmp}/cpgmatch-install.XXXXXX")
EMU_PID=
trap '[[ -n $EMU_PID ]] && kill "$EMU_PID" 2>/dev/null; rm -rf "$WORK"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

PREFIX=$WORK/prefix
cmake --install "$BUILD" --prefix "$PREFIX" >"$WORK/install.log" || { cat "$WORK/install.log"; fail "cmake --install"; }
EXES=(cpgmatch cpgmatch-optimizer cpgmatch-sim-worker cpgmatch-robot-agent cpgmatch-robot-emulator)
for f in "${EXES[@]/#/bin/}" share/cpgmatch/configs/robot/morti.yaml \
         share/cpgmatch/configs/model/morti.yaml share/cpgmatch/configs/rollout.yaml \
         share/cpgmatch/configs/params/default.yaml share/cpgmatch/configs/spaces/paper.yaml \
         share/cpgmatch/fastdds/local.xml share/cpgmatch/fastdds/cluster.xml share/cpgmatch/fastdds/udp-only.xml \
         share/cpgmatch/idl/cpgmatch_msgs.idl share/doc/cpgmatch/copyright share/doc/cpgmatch/CITATION.cff \
         share/cpgmatch/idl/cpgmatch_ros2_msgs.idl share/cpgmatch/ros2/cpgmatch_msgs/package.xml \
         share/cpgmatch/ros2/cpgmatch_msgs/CMakeLists.txt share/cpgmatch/ros2/cpgmatch_msgs/msg/StudyState.msg \
         lib/systemd/system/cpgmatch-optimizer.service lib/systemd/system/cpgmatch-sim-worker@.service \
         lib/systemd/system/cpgmatch-discovery.service; do
  [[ -e $PREFIX/$f ]] || fail "not installed: $f"
done
# Units name the executables of the prefix they were installed into.
grep -q "^ExecStart=$PREFIX/bin/cpgmatch-optimizer " "$PREFIX/lib/systemd/system/cpgmatch-optimizer.service" ||
  fail "optimizer unit does not start $PREFIX/bin/cpgmatch-optimizer"
# Man pages: one per command and subcommand, and the study file's keys in section 5, all written from the
# programs' own definitions; they render (groff) with "±" as itself, not "??".
for exe in "${EXES[@]}"; do
  [[ -s $PREFIX/share/man/man1/$exe.1.gz ]] || fail "no man page for $exe"
done
for page in cpgmatch-study-run cpgmatch-study-submit cpgmatch-export cpgmatch-reproduce cpgmatch-calibrate; do
  [[ -s $PREFIX/share/man/man1/$page.1.gz ]] || fail "no man page for the subcommand: $page.1.gz"
done
[[ -s $PREFIX/share/man/man5/cpgmatch-study.5.gz ]] || fail "no cpgmatch-study(5)"
for exe in cpgmatch-sim-worker cpgmatch-robot-agent; do
  zcat "$PREFIX/share/man/man1/$exe.1.gz" | grep -qF 'dds\-profile' || fail "the man page of $exe lacks its DDS flags"
done
zcat "$PREFIX/share/man/man1/cpgmatch-robot-emulator.1.gz" | grep -qF 'lockstep' || fail "the emulator's man page lacks its flags"
zcat "$PREFIX/share/man/man1/cpgmatch-study-run.1.gz" | grep -qF 'config' || fail "cpgmatch-study-run(1) lacks --config"
rendered=$(zcat "$PREFIX/share/man/man1/cpgmatch.1.gz" | LC_ALL=C.UTF-8 groff -man -Tutf8 -P-cbou 2>&1) || fail "groff: $rendered"
[[ $rendered == *"±"* ]] || fail "cpgmatch(1) does not render ±"
[[ $rendered != *"??"* ]] || fail "cpgmatch(1) renders '??'"
study5=$(zcat "$PREFIX/share/man/man5/cpgmatch-study.5.gz" | LC_ALL=C.UTF-8 groff -man -Tutf8 -P-cbou 2>&1) || fail "groff: $study5"
for key in budget initial_design hardware.strategy rollout_settings base_parameters; do
  [[ $study5 == *"$key"* ]] || fail "cpgmatch-study(5) lacks the key $key"
done

# From an unrelated folder, with no hint at the source tree.
mkdir -p "$WORK/elsewhere" && cd "$WORK/elsewhere"
unset CPGMATCH_CONFIG_DIR FASTRTPS_DEFAULT_PROFILES_FILE ROS_DISCOVERY_SERVER
for exe in "${EXES[@]}"; do
  v=$("$PREFIX/bin/$exe" --version) || fail "$exe --version exited $?"
  [[ $v =~ ^$exe\ [0-9]+\.[0-9]+\.[0-9]+\ \(git\ [^\)]+\)$ ]] || fail "$exe --version: '$v'"
done

# The configs really come from the prefix: break the installed default parameters and the rollout names
# the installed file; repair them and it runs.
params=$PREFIX/share/cpgmatch/configs/params/default.yaml
cp "$params" "$WORK/default.yaml.good"
echo "frequency: [not, a, number]" >"$params"
out=$("$PREFIX/bin/cpgmatch" rollout --entrain 0.5 --eval 0.5 --json 2>&1) && fail "a broken installed config was not read"
[[ $out == *"$params"* ]] || fail "the error does not name the installed config: $out"
cp "$WORK/default.yaml.good" "$params"
# The same for the robot description the agent and the emulator read by default.
robot=$PREFIX/share/cpgmatch/configs/robot/morti.yaml
cp "$robot" "$WORK/morti.yaml.good"
echo "control_rate_hz: [not, a, number]" >"$robot"
set +e
out=$("$PREFIX/bin/cpgmatch-robot-agent" --can udp:127.0.0.1:9 --run-once 2>&1); rc=$?
[[ $rc == 2 && $out == *"$robot"* ]] || fail "the agent did not read the installed robot description: exit $rc, '$out'"
out=$(timeout 20 "$PREFIX/bin/cpgmatch-robot-emulator" --can udp:127.0.0.1:9 2>&1); rc=$?
[[ $rc == 2 && $out == *"$robot"* ]] || fail "the emulator did not read the installed robot description: exit $rc, '$out'"
set -e
cp "$WORK/morti.yaml.good" "$robot"

# The prefix can be moved: the binaries find share/ relative to themselves.
mv "$PREFIX" "$WORK/moved"
PREFIX=$WORK/moved
out=$("$PREFIX/bin/cpgmatch" rollout --entrain 0.5 --eval 0.5 --json) || fail "rollout from the moved prefix failed"
[[ $out == *'"cost"'* ]] || fail "rollout printed no cost: $out"

# $CPGMATCH_CONFIG_DIR overrides, and a wrong one is a clear input error.
set +e
out=$(CPGMATCH_CONFIG_DIR=$WORK/nowhere "$PREFIX/bin/cpgmatch" rollout --json 2>&1); rc=$?
set -e
[[ $rc == 2 && $out == *CPGMATCH_CONFIG_DIR*nowhere* ]] || fail "bad CPGMATCH_CONFIG_DIR: exit $rc, '$out'"
set +e
out=$("$PREFIX/bin/cpgmatch-sim-worker" --dds-profile no-such-profile 2>&1); rc=$?
set -e
[[ $rc == 2 && $out == *--dds-profile*no-such-profile* ]] || fail "bad --dds-profile: exit $rc, '$out'"
set +e
out=$("$PREFIX/bin/cpgmatch-robot-agent" --can udp:127.0.0.1:9 --dds-profile no-such-profile 2>&1); rc=$?
set -e
[[ $rc == 2 && $out == *--dds-profile*no-such-profile* ]] || fail "agent, bad --dds-profile: exit $rc, '$out'"

# The robot agent against the emulator, both from the moved prefix with their default model, settings and
# parameters (the agent's robot description relaxed for this loaded machine, as in tests/robot/).
sed -e 's/^protocol: mit/emulator_only: true\nprotocol: mit/' -e 's/feedback_timeout_s: 0.010/feedback_timeout_s: 0.5/' \
    -e 's/max_consecutive_overruns: 5 /max_consecutive_overruns: 100 /' \
  "$PREFIX/share/cpgmatch/configs/robot/morti.yaml" >"$WORK/robot.yaml"
grep -q "max_consecutive_overruns: 100 " "$WORK/robot.yaml" || fail "the relaxed robot description lost its overrun limit"
PORT=$(python3 -c 'import socket; s=socket.socket(socket.AF_INET, socket.SOCK_DGRAM); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')
"$PREFIX/bin/cpgmatch-robot-emulator" --can "udp:127.0.0.1:$PORT" --lockstep >"$WORK/emulator.log" 2>&1 &
EMU_PID=$!
sleep 0.3
out=$("$PREFIX/bin/cpgmatch-robot-agent" --can "udp:127.0.0.1:$PORT" --robot "$WORK/robot.yaml" --lockstep --no-realtime \
      --run-once --entrain 0.5 --eval 0.5 --json 2>"$WORK/agent.log") ||
  { cat "$WORK/emulator.log" "$WORK/agent.log" >&2; fail "agent rollout from the prefix: $out"; }
[[ $out == *'"ok":true'* && $out == *'"loop"'* ]] || fail "agent rollout from the prefix: $out"
kill -TERM "$EMU_PID"; wait "$EMU_PID" || fail "the installed emulator exited $? after SIGTERM"; EMU_PID=

# A tiny study through the installed services (optimizer and workers are the prefix's own executables).
cat >"$WORK/tiny.yaml" <<YAML
name: installed
budget: 4
initial_points: 2
seed: 5
rollout: {entrain_s: 0.5, eval_s: 0.5}
YAML
"$PREFIX/bin/cpgmatch" study run --config "$WORK/tiny.yaml" --workers 2 --out "$WORK/out" --jitter 0 --json \
  >"$WORK/study.json" 2>"$WORK/study.log" || { tail -n 30 "$WORK/study.log" >&2; fail "study run from the installed prefix"; }
done_trials=$(sqlite3 "$WORK/out/study.db" "select count(*) from trials where status='done'")
[[ $done_trials == 4 ]] || fail "the study store holds $done_trials done trials, not 4"
[[ -s $WORK/out/analysis.json ]] || fail "no analysis.json in --out"
echo "PASS install: prefix layout, --version, configs from the prefix (moved too), tiny study of 4, agent rollout on the emulator"
