#!/usr/bin/env bash
# A Cyclone DDS reader without a certificate reads nothing from secure services. Everything runs in a
# network namespace of its own (loopback only, multicast routed to it), so discovery is plain multicast
# SPDP, the way another vendor's program would join, and no packet leaves the namespace. Control: the
# same reader reads the final state of a plain study there; then, with DDS-Security on, it reads no sample.
# Needs root; SKIP (exit 77) where namespaces cannot be made.
#   BIN=build/bin DOMAIN=52 READER=build/tests/cyclone_state_reader test_secure_cyclone.sh
source "$(dirname "$0")/../integration/lib.sh"
READER=${READER:?READER must point at cyclone_state_reader}
NS=cpgsec$(( $$ % 100000 ))
if ! why=$(ip netns add "$NS" 2>&1); then
  echo "SKIP: cannot create network namespaces: ${why:-ip netns add failed} (needs root / CAP_SYS_ADMIN)"
  exit 77
fi
remove_namespace() {
  local pid
  for pid in $(ip netns pids "$NS" 2>/dev/null); do kill -9 "$pid" 2>/dev/null || true; done
  ip netns del "$NS" 2>/dev/null || true
  cleanup
}
trap remove_namespace EXIT
if ! why=$( { ip -n "$NS" link set lo multicast on up && ip -n "$NS" route add 224.0.0.0/4 dev lo &&
              ip netns exec "$NS" true; } 2>&1); then
  echo "SKIP: cannot create network namespaces: configuring one fails: $why"
  exit 77
fi
in_ns() { ip netns exec "$NS" "$@"; }
"$(dirname "$0")/../../deploy/make-study-pki.sh" "$WORK/ks" --days 2 >/dev/null

# study TAG [security flags]: optimizer + worker (UDP, multicast discovery) and a study of 8 to the end
study() {
  local tag=$1; shift
  in_ns "$BIN/cpgmatch-optimizer" --domain "$DOMAIN" --store "$WORK/$tag.db" "$@" >>"$WORK/optimizer-$tag.log" 2>&1 &
  PIDS+=($!)
  in_ns "$BIN/cpgmatch-sim-worker" --domain "$DOMAIN" --id "worker/w-$tag" --slots 2 --fake-rollout-ms 10 "$@" \
    >>"$WORK/worker-$tag.log" 2>&1 &
  PIDS+=($!)
  in_ns "$BIN/cpgmatch" study submit --config "$WORK/$tag.yaml" --wait --quiet --domain "$DOMAIN" --timeout 20 "$@" \
    >/dev/null 2>>"$WORK/cli.log" || fail "$tag study did not finish"
}
export FASTRTPS_DEFAULT_PROFILES_FILE="$(cd "$(dirname "$0")/../.." && pwd)/deploy/fastdds/udp-only.xml"
write_study "$WORK/plain.yaml" plain 8
write_study "$WORK/secure.yaml" secret 6
study plain
out=$(in_ns "$READER" "$DOMAIN" 1 15) || fail "control: the Cyclone DDS reader read nothing from the plain study"
[[ $out == *"state done completed 8 budget 8"* ]] || fail "control read: $out"
# `ip netns exec` forks: the services are the namespace's processes, not the pids we hold.
for pid in $(ip netns pids "$NS"); do kill -9 "$pid" 2>/dev/null || true; done
wait 2>/dev/null || true
PIDS=()
sleep 0.2
[[ -z $(ip netns pids "$NS") ]] || fail "the plain services are still running"
study secure --keystore "$WORK/ks"
set +e
out=$(in_ns "$READER" "$DOMAIN" 1 8 2>&1); rc=$?
set -e
[[ $rc != 0 && $out != *"state done"* && $out != *secret* ]] || fail "the Cyclone DDS reader without a certificate read the secure state: $out"
echo "PASS Cyclone DDS without a certificate: read the plain study's state (control), nothing from the secure" \
     "services (reader exit $rc)"
