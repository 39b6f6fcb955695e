#!/usr/bin/env bash
# The .deb that CPack builds: Debian dependencies computed from what the executables link (dpkg-shlibdeps)
# plus fastdds-tools, files under /usr where Debian expects them, units starting /usr/bin executables, and
# apt able to resolve it on this machine (simulated: nothing is installed). The unpacked tree runs a
# rollout with the configs it carries.
#   test_deb.sh BUILD_DIR
set -euo pipefail
BUILD=${1:?usage: test_deb.sh BUILD_DIR}
WORK=$(mktemp -d "${TMPDIR:-/tmp}/cpgmatch-deb.XXXXXX")
trap 'rm -rf "$WORK"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
command -v dpkg-shlibdeps >/dev/null || { echo "SKIP: dpkg-shlibdeps (dpkg-dev) is not installed"; exit 77; }

cpack --config "$BUILD/CPackConfig.cmake" -G DEB -B "$WORK" >"$WORK/cpack.log" 2>&1 || { cat "$WORK/cpack.log"; fail "cpack"; }
deb=$(ls "$WORK"/cpgmatch_*.deb) || fail "no .deb in $WORK"
depends=$(dpkg-deb -f "$deb" Depends)
# (No libcpp-httplib: the dashboard serves HTTP itself since issue 34.)
for needed in fastdds-tools libfastrtps2.9 libode8 libsqlite3-0 libyaml-cpp0.7 libnlopt0 libgsl27 libjs-chart.js; do
  [[ $depends == *"$needed"* ]] || fail "Depends lacks $needed: $depends"
done
dpkg-deb -x "$deb" "$WORK/root"
for f in usr/bin/cpgmatch usr/bin/cpgmatch-optimizer usr/bin/cpgmatch-sim-worker usr/share/cpgmatch/configs/model/morti.yaml \
         usr/bin/cpgmatch-robot-agent usr/bin/cpgmatch-robot-emulator usr/share/cpgmatch/configs/robot/morti.yaml \
         usr/share/cpgmatch/fastdds/cluster.xml usr/lib/systemd/system/cpgmatch-optimizer.service \
         usr/lib/systemd/system/cpgmatch-robot-agent.service; do
  [[ -e $WORK/root/$f ]] || fail "not in the package: /$f"
done
# Debian's licence file, the citation, the DDS contract and every Fast DDS profile the source tree has.
SRC=$(cd "$(dirname "$0")/../.." && pwd)
for f in usr/share/doc/cpgmatch/copyright usr/share/doc/cpgmatch/CITATION.cff usr/share/cpgmatch/idl/cpgmatch_msgs.idl; do
  [[ -s $WORK/root/$f ]] || fail "not in the package: /$f"
done
for profile in "$SRC"/deploy/fastdds/*.xml; do
  [[ -s $WORK/root/usr/share/cpgmatch/fastdds/$(basename "$profile") ]] || fail "Fast DDS profile not in the package: $(basename "$profile")"
done
head -1 "$WORK/root/usr/share/doc/cpgmatch/copyright" | grep -q '^Format: https://www.debian.org/doc/packaging-manuals/copyright-format/1.0/' ||
  fail "/usr/share/doc/cpgmatch/copyright is not in Debian's machine-readable format"
grep -q '^License: MIT' "$WORK/root/usr/share/doc/cpgmatch/copyright" || fail "copyright names no licence"
grep -q '^ExecStart=/usr/bin/cpgmatch-optimizer ' "$WORK/root/usr/lib/systemd/system/cpgmatch-optimizer.service" ||
  fail "the packaged optimizer unit does not start /usr/bin/cpgmatch-optimizer"
apt-get install -s "$deb" >"$WORK/apt.log" 2>&1 || { cat "$WORK/apt.log"; fail "apt cannot resolve the package's dependencies"; }
cd "$WORK"
unset CPGMATCH_CONFIG_DIR
"$WORK/root/usr/bin/cpgmatch" rollout --entrain 0.5 --eval 0.5 --json | grep -q '"cost"' || fail "rollout from the unpacked package"
v=$("$WORK/root/usr/bin/cpgmatch-robot-agent" --version) || fail "the packaged agent's --version exited $?"
[[ $v == "cpgmatch-robot-agent "* ]] || fail "the packaged agent's --version: '$v'"
echo "PASS deb: $(basename "$deb"), Depends: $depends"
