#!/usr/bin/env bash
# Installs every Debian 12 package cpgmatch needs to build, test and run.
# Idempotent: packages already installed are skipped, so a second run is quick and offline.
# Runs as root, through sudo otherwise; says clearly when neither is possible.
set -euo pipefail

PACKAGES=(
  # toolchain
  cmake g++ make pkg-config
  # transport
  libfastrtps-dev fastddsgen fastdds-tools
  # DDS-Security: keystores (deploy/make-study-pki.sh) and their certificate checks
  openssl libssl-dev
  # a second DDS vendor, for the cross-vendor test (Cyclone DDS reads our study state)
  cyclonedds-dev cyclonedds-tools
  # science: linear algebra, physics, optimisation, quasi-random sequences
  libeigen3-dev libode-dev libnlopt-dev libnlopt-cxx-dev libceres-dev libgsl-dev
  # configuration, CLI, logging, JSON, storage
  libyaml-cpp-dev libcli11-dev libspdlog-dev libfmt-dev nlohmann-json3-dev libsqlite3-dev sqlite3
  # tests, benchmarks, plots
  libgtest-dev libgmock-dev libbenchmark-dev gnuplot-nox time python3
  # `cpgmatch export --format optuna-journal` is tested by loading the journal in Optuna (3.1 in Debian 12)
  # and drawing its plots (plotly)
  python3-optuna python3-plotly
  # the live dashboard (cpgmatch dashboard) and report.html work offline: an HTTP server library and
  # Chart.js from Debian, never a CDN; headless Chromium loads both in the browser tests
  libcpp-httplib-dev libjs-chart.js chromium
  # installation and packaging: groff renders the man pages in the install test, dpkg-shlibdeps finds the
  # .deb's dependencies, network namespaces for the cluster test
  groff-base dpkg-dev iproute2
  # robot descriptions (configs/robots/*/robot.urdf) are parsed with urdfdom
  liburdfdom-dev libtinyxml2-dev
)

missing=()
for pkg in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$pkg")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#PACKAGES[@]} packages already installed"
  exit 0
fi

if [ "$(id -u)" -eq 0 ]; then
  SUDO=()
elif command -v sudo >/dev/null 2>&1 && sudo -n true 2>/dev/null; then
  SUDO=(sudo)
else
  echo "install-deps: need root to install: ${missing[*]}" >&2
  echo "install-deps: run this script as root, or give this user password-less sudo." >&2
  exit 1
fi

echo "install-deps: installing ${#missing[@]} package(s): ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
"${SUDO[@]}" apt-get update -q
"${SUDO[@]}" apt-get install -y -q --no-install-recommends "${missing[@]}"
echo "install-deps: done"
