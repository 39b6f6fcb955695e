#!/usr/bin/env bash
# `cmake --install` into a temporary prefix, then use the installed programs the way a user would: from
# another folder, with nothing pointing at the source tree. Proves the installed binaries find their
# configs and Fast DDS profiles under <prefix>/share/cpgmatch (also after moving the prefix), print their
# version, and run a rollout and a tiny study; units and man pages are where Debian expects them.
#   test_install.sh BUILD_DIR
set -euo pipefail
BUILD=${1:?usage: test_install.sh BUILD_DIR}
WORK=$(mktemp -d "${TMPDIR:-/tmp}/cpgmatch-install.XXXXXX")
trap 'rm -rf "$WORK"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

PREFIX=$WORK/prefix
cmake --install "$BUILD" --prefix "$PREFIX" >"$WORK/install.log" || { cat "$WORK/install.log"; fail "cmake --install"; }
for f in bin/cpgmatch bin/cpgmatch-optimizer bin/cpgmatch-sim-worker \
         share/cpgmatch/configs/model/morti.yaml share/cpgmatch/configs/rollout.yaml \
         share/cpgmatch/configs/params/default.yaml share/cpgmatch/configs/spaces/paper.yaml \
         share/cpgmatch/fastdds/local.xml share/cpgmatch/fastdds/cluster.xml \
         lib/systemd/system/cpgmatch-optimizer.service lib/systemd/system/cpgmatch-sim-worker@.service \
         lib/systemd/system/cpgmatch-discovery.service; do
  [[ -e $PREFIX/$f ]] || fail "not installed: $f"
done
# Units name the executables of the prefix they were installed into.
grep -q "^ExecStart=$PREFIX/bin/cpgmatch-optimizer " "$PREFIX/lib/systemd/system/cpgmatch-optimizer.service" ||
  fail "optimizer unit does not start $PREFIX/bin/cpgmatch-optimizer"
if command -v help2man >/dev/null; then
  for exe in cpgmatch cpgmatch-optimizer cpgmatch-sim-worker; do
    [[ -s $PREFIX/share/man/man1/$exe.1.gz ]] || fail "no man page for $exe"
  done
  zcat "$PREFIX/share/man/man1/cpgmatch-sim-worker.1.gz" | grep -qF 'dds\-profile' || fail "the worker's man page lacks its flags"
fi

# From an unrelated folder, with no hint at the source tree.
mkdir -p "$WORK/elsewhere" && cd "$WORK/elsewhere"
unset CPGMATCH_CONFIG_DIR FASTRTPS_DEFAULT_PROFILES_FILE ROS_DISCOVERY_SERVER
for exe in cpgmatch cpgmatch-optimizer cpgmatch-sim-worker; do
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
echo "PASS install: prefix layout, --version, configs from the prefix (moved too), tiny study of 4"
