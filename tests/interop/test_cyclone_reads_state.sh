#!/usr/bin/env bash
# Cross-vendor: a study run by the Fast DDS services (UDP, multicast discovery), then a Cyclone DDS reader
# started afterwards reads its final state from cpgmatch/study_state.
source "$(dirname "$0")/../integration/lib.sh"
READER=${READER:?READER must point at cyclone_state_reader}
# UDP only on the Fast DDS side (Cyclone cannot use Fast DDS's shared memory anyway).
export FASTRTPS_DEFAULT_PROFILES_FILE="$(cd "$(dirname "$0")/../.." && pwd)/deploy/fastdds/udp-only.xml"
write_study "$WORK/s.yaml" interop 8
"$BIN/cpgmatch-optimizer" --domain "$DOMAIN" --store "$WORK/s.db" >>"$WORK/optimizer.log" 2>&1 &
PIDS+=($!)
"$BIN/cpgmatch-sim-worker" --domain "$DOMAIN" --id iw --slots 2 --fake-rollout-ms 10 >>"$WORK/worker.log" 2>&1 &
PIDS+=($!)
"$BIN/cpgmatch" study submit --config "$WORK/s.yaml" --wait --quiet --domain "$DOMAIN" --timeout 20 \
  >/dev/null 2>>"$WORK/cli.log" || fail "submit --wait failed"
out=$("$READER" "$DOMAIN" 1 20) || fail "the Cyclone DDS reader got no state"
[[ $out == *"state done completed 8 budget 8"* ]] || fail "Cyclone read: $out"
echo "PASS Cyclone DDS reads the Fast DDS study state: $out"
