#!/usr/bin/env bash
# The robot agent's arm64 package (deploy/cross-build-arm64.sh builds it): the agent is an aarch64 binary
# under /usr/bin, its configs and Fast DDS profiles are where the agent looks for them (../share/cpgmatch
# beside the binary), every shared library the binary needs (readelf NEEDED) is provided by a package in
# Depends, and apt can resolve Depends for arm64 on this (multiarch) machine. Run by the cross-build script;
# not a ctest test, since the cross toolchain is not part of the normal build.
#   test_arm64_deb.sh ARM64_BUILD_DIR
set -euo pipefail
OUT=${1:?usage: test_arm64_deb.sh ARM64_BUILD_DIR}
fail() { echo "FAIL arm64 deb: $*" >&2; exit 1; }
deb=$(ls "$OUT"/cpgmatch-robot-agent_*_arm64.deb 2>/dev/null | head -1)
[[ -n $deb ]] || fail "no cpgmatch-robot-agent_*_arm64.deb in $OUT"
WORK=$(mktemp -d "${TMPDIR:-/tmp}/cpgmatch-arm64deb.XXXXXX")
trap 'rm -rf "$WORK"' EXIT
dpkg-deb -x "$deb" "$WORK/root"
[[ $(dpkg-deb -f "$deb" Architecture) == arm64 ]] || fail "Architecture is $(dpkg-deb -f "$deb" Architecture)"
agent=$WORK/root/usr/bin/cpgmatch-robot-agent
file "$agent" | grep -q "ARM aarch64" || fail "the packaged agent is not an aarch64 executable: $(file "$agent")"
for f in usr/share/cpgmatch/configs/robot/morti.yaml usr/share/cpgmatch/configs/rollout.yaml \
         usr/share/cpgmatch/fastdds/cluster.xml usr/lib/systemd/system/cpgmatch-robot-agent.service; do
  [[ -e $WORK/root/$f ]] || fail "not in the package: /$f"
done
grep -q "^ExecStart=.*exec /usr/bin/cpgmatch-robot-agent " "$WORK/root/usr/lib/systemd/system/cpgmatch-robot-agent.service" ||
  fail "the packaged unit does not start /usr/bin/cpgmatch-robot-agent"
depends=$(dpkg-deb -f "$deb" Depends)
# Each NEEDED library -> the arm64 package that ships it (dpkg -S, or the sysroot's extracted .debs).
for lib in $(readelf -d "$agent" | sed -n 's/.*Shared library: \[\(.*\)\]/\1/p'); do
  pkg=$(dpkg -S "/usr/lib/aarch64-linux-gnu/$lib" "/lib/aarch64-linux-gnu/$lib" 2>/dev/null | head -1 | cut -d: -f1 || true)
  if [[ -z $pkg && -d $OUT/debs ]]; then
    for d in "$OUT"/debs/*.deb; do
      dpkg-deb -c "$d" | grep -q "/$lib\$\|/$lib -> " && pkg=$(dpkg-deb -f "$d" Package) && break
    done
  fi
  [[ -n $pkg ]] || fail "no package found for $lib"
  [[ $depends == *"$pkg"* ]] || fail "$lib comes from $pkg, which Depends lacks: $depends"
done
apt-get install -s "$deb" >"$WORK/apt.log" 2>&1 || { cat "$WORK/apt.log"; fail "apt cannot resolve Depends for arm64"; }
echo "PASS arm64 deb: $(basename "$deb"), Depends: $depends"
