#!/usr/bin/env bash
# The physics engine is loaded only by what simulates (issue 31): the optimizer service and the robot agent read
# models and robot descriptions through cpgmatch_sim_model and must not link ODE; the simulation worker and the
# emulator must (which shows the check can see it).
set -euo pipefail
fail() { echo "FAIL: $*" >&2; exit 1; }
# ldd's output whole, then matched: `ldd | grep -q` under pipefail fails when grep stops reading early.
links_ode() { local libs; libs=$(ldd "$BIN/$1"); [[ $libs == *libode.so* ]]; }
for b in cpgmatch-optimizer cpgmatch-robot-agent; do
  [[ -x $BIN/$b ]] || fail "$b is not built"
  if links_ode "$b"; then fail "$b links the physics engine (libode.so in ldd $BIN/$b)"; fi
done
for b in cpgmatch-sim-worker cpgmatch-robot-emulator; do
  links_ode "$b" || fail "$b does not link ODE, so this test could not tell"
done
echo "PASS: cpgmatch-optimizer and cpgmatch-robot-agent link no libode; cpgmatch-sim-worker and cpgmatch-robot-emulator do"
