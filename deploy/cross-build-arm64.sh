#!/usr/bin/env bash
# Cross-builds the robot agent for the Pi (arm64) with Debian's cross toolchain and multiarch packages,
# then runs the cross-built robot unit tests under qemu-user. Slow; not part of tools/run-tests.sh.
#   deploy/cross-build-arm64.sh [BUILD_DIR]        (default build-arm64; as root: it installs packages)
# Result: BUILD_DIR/bin/cpgmatch-robot-agent (aarch64) and BUILD_DIR/bin/robot_tests.
set -euo pipefail
ROOT="$(cd "$(dirname "$0")/.." && pwd)"
OUT=${1:-$ROOT/build-arm64}
start=$SECONDS

if ! dpkg --print-foreign-architectures | grep -qx arm64; then dpkg --add-architecture arm64; fi
# Only packages that are co-installable with their amd64 twins (Multi-Arch: same) go into the system.
# libyaml-cpp-dev is not: installing its arm64 package removes the host's, and with it every native
# build on this machine. Its arm64 files go into a private sysroot below instead, and so do libgsl-dev's
# (not Multi-Arch at all; its arm64 runtime libraries are, and are installed).
packages=(crossbuild-essential-arm64 qemu-user cmake pkg-config fastddsgen libeigen3-dev nlohmann-json3-dev libcli11-dev
          libyaml-cpp-dev libfmt-dev:arm64 libspdlog-dev:arm64 libgtest-dev:arm64
          libfastrtps-dev:arm64 libfastcdr-dev:arm64
          libnlopt-dev:arm64 libnlopt-cxx-dev:arm64 libsqlite3-dev:arm64 libssl-dev:arm64
          liburdfdom-headers-dev liburdfdom-dev:arm64 libtinyxml2-dev:arm64 libconsole-bridge-dev:arm64
          libgsl-dev libgsl27:arm64 libgslcblas0:arm64)
missing=()
for p in "${packages[@]}"; do dpkg -s "$p" >/dev/null 2>&1 || missing+=("$p"); done
if ((${#missing[@]})); then
  apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends "${missing[@]}"
fi
SYSROOT="$OUT/sysroot"
YAML_DIR="$SYSROOT/usr/lib/aarch64-linux-gnu/cmake/yaml-cpp"
if [[ ! -f $YAML_DIR/yaml-cpp-config.cmake ]]; then
  mkdir -p "$OUT/debs"
  (cd "$OUT/debs" && apt-get download libyaml-cpp-dev:arm64 libyaml-cpp0.7:arm64)
  for deb in "$OUT"/debs/*.deb; do dpkg-deb -x "$deb" "$SYSROOT"; done
fi
if [[ ! -f $SYSROOT/usr/lib/aarch64-linux-gnu/libgsl.so ]]; then
  mkdir -p "$OUT/debs"
  (cd "$OUT/debs" && apt-get download libgsl-dev:arm64 libgsl27:arm64 libgslcblas0:arm64)
  for deb in "$OUT"/debs/libgsl*.deb; do dpkg-deb -x "$deb" "$SYSROOT"; done
fi
echo "packages ready after $((SECONDS - start)) s"

cmake -S "$ROOT/deploy/arm64" -B "$OUT" -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_TOOLCHAIN_FILE="$ROOT/deploy/arm64/toolchain-aarch64.cmake" -Dyaml-cpp_DIR="$YAML_DIR" \
  -DGSL_INCLUDE_DIR=/usr/include -DGSL_LIBRARY="$SYSROOT/usr/lib/aarch64-linux-gnu/libgsl.so" \
  -DGSL_CBLAS_LIBRARY="$SYSROOT/usr/lib/aarch64-linux-gnu/libgslcblas.so" >/dev/null
nice -n 10 cmake --build "$OUT" -j2 --target cpgmatch-robot-agent robot_tests
echo "built after $((SECONDS - start)) s"
file "$OUT/bin/cpgmatch-robot-agent" "$OUT/bin/robot_tests"
(cd "$OUT" && cpack -G DEB >cpack.log 2>&1) || { cat "$OUT/cpack.log"; exit 1; }
echo "package: $(ls "$OUT"/cpgmatch-robot-agent_*_arm64.deb)"
bash "$ROOT/tests/deploy/test_arm64_deb.sh" "$OUT"

# Under qemu-user the CAN layer, the protocols, the robot YAML, the device side and the jitter
# statistics run. Excluded: the timing tests (PeriodicTimer) and the CanPlant suite, whose tests start
# threads: under qemu-user 7.2 on the development machine no program that starts a thread finishes (a
# five-line std::thread program hangs too). It passes natively on amd64 (ctest); run it on a real arm64.
nice -n 10 timeout 600 qemu-aarch64 -L /usr/aarch64-linux-gnu "$OUT/bin/robot_tests" --gtest_filter='-CanPlant.*:PeriodicTimer.*'
echo "cross-build and qemu tests done in $((SECONDS - start)) s"
