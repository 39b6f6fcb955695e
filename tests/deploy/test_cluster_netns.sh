#!/usr/bin/env bash
# A study across "hosts" on this one machine, discovered through a Fast DDS discovery server, without
# multicast. Each host is a network namespace; they are joined by veth links to a bridge that lives in a
# namespace of its own, so no packet ever touches the machine's real network:
#
#   ns "opt"  10.77.0.1  fastdds discovery server + cpgmatch-optimizer (+ the operator's submit)
#   ns "wa"   10.77.0.2  cpgmatch-sim-worker wa
#   ns "wb"   10.77.0.3  cpgmatch-sim-worker wb
#   ns "view" 10.77.0.4  cpgmatch status (read only)
#   ns "sw"   bridge br0, one veth per host
#
# Multicast is switched off on every link. Study 1 completes; during study 2, wb's link goes down for
# longer than the worker timeout and comes back: the optimizer re-issues wb's candidates, wb rejoins, and
# the study finishes with every trial counted exactly once. Namespaces and processes are removed by a trap
# even when the test fails. Needs root (CAP_NET_ADMIN); says SKIP and exits 77 where namespaces cannot be made.
#   BIN=build/bin DOMAIN=50 test_cluster_netns.sh
set -euo pipefail
BIN=${BIN:?BIN must point at build/bin}
DOMAIN=${DOMAIN:?DOMAIN must be set}
WORK=$(mktemp -d "${TMPDIR:-/tmp}/cpgmatch-netns.XXXXXX")
TAG=c$(( $$ % 100000 ))          # unique per run: namespace and interface names (interfaces <= 15 chars)
HOSTS=(opt wa wb view)
declare -A ADDR=([opt]=10.77.0.1 [wa]=10.77.0.2 [wb]=10.77.0.3 [view]=10.77.0.4)
SERVER=${ADDR[opt]}:11811
PIDS=()
NAMESPACES=()

ns() { echo "$TAG-$1"; }
in_ns() { local n=$1; shift; ip netns exec "$(ns "$n")" "$@"; }

cleanup() {
  local pid n
  exec 2>/dev/null  # the shell's "Killed" notices for our own background processes are noise
  for pid in "${PIDS[@]}"; do kill -9 "$pid" 2>/dev/null || true; done
  for n in "${NAMESPACES[@]}"; do
    # Anything still running inside one of our namespaces was started by this test.
    for pid in $(ip netns pids "$n" 2>/dev/null); do kill -9 "$pid" 2>/dev/null || true; done
    ip netns del "$n" 2>/dev/null || true
  done
  wait 2>/dev/null || true
  if [[ ${KEEP_WORK:-0} == 1 ]]; then echo "work dir kept: $WORK"; else rm -rf "$WORK"; fi
}
trap cleanup EXIT

fail() {
  echo "FAIL: $*" >&2
  for f in "$WORK"/*.log; do [[ -f $f ]] && { echo "--- $f" >&2; tail -n 25 "$f" >&2; }; done
  exit 1
}

# ---- the network --------------------------------------------------------------------------------------
if ! why=$(ip netns add "$(ns sw)" 2>&1); then
  echo "SKIP: cannot create network namespaces: ${why:-ip netns add failed} (needs root / CAP_SYS_ADMIN)"
  exit 77
fi
NAMESPACES+=("$(ns sw)")
# No multicast crosses the bridge: snooping off makes every group "unregistered", and no port floods those.
# A container may allow the namespace but not entering it or making links in it: that is a skip too.
if ! why=$(in_ns sw ip link add br0 type bridge mcast_snooping 0 2>&1); then
  echo "SKIP: cannot create network namespaces: a bridge inside one fails: $why"
  exit 77
fi
in_ns sw ip link set br0 multicast off
in_ns sw ip link set br0 up
for h in "${HOSTS[@]}"; do
  ip netns add "$(ns "$h")"
  NAMESPACES+=("$(ns "$h")")
  # The pair is created inside the host's namespace and one end moved to the switch: the root namespace
  # never holds either end.
  in_ns "$h" ip link add eth0 type veth peer name "p-$h"
  in_ns "$h" ip link set "p-$h" netns "$(ns sw)"
  in_ns sw ip link set "p-$h" master br0 multicast off up
  in_ns sw bridge link set dev "p-$h" mcast_flood off
  in_ns "$h" ip addr add "${ADDR[$h]}/24" dev eth0
  in_ns "$h" ip link set eth0 multicast off up
  in_ns "$h" ip link set lo up
done
for h in "${HOSTS[@]}"; do
  in_ns "$h" ip -o link show eth0 | grep -q MULTICAST && fail "multicast is still on in $h"
done

# ---- control: multicast discovery (the local profile) does not cross this network --------------------
# A worker with Fast DDS's default discovery is seen from its own namespace but not from another one.
in_ns wa "$BIN/cpgmatch-sim-worker" --domain "$DOMAIN" --dds-profile local --id probe --slots 1 >>"$WORK/probe.log" 2>&1 &
PROBE_PID=$!
PIDS+=("$PROBE_PID")
seen_from() { in_ns "$1" "$BIN/cpgmatch" workers --json --domain "$DOMAIN" --dds-profile local --timeout 2 2>>"$WORK/cli.log"; }
[[ $(seen_from wa) == *'"probe"'* ]] || fail "control: the probe worker is not seen even from its own namespace"
[[ $(seen_from view) == '[]' ]] || fail "control: multicast discovery crossed namespaces, the network is not multicast-free"
kill -TERM "$PROBE_PID"; wait "$PROBE_PID" 2>/dev/null || true

# ---- the cluster --------------------------------------------------------------------------------------
DDS=(--domain "$DOMAIN" --dds-profile cluster --discovery-server "$SERVER")
start() {  # start NS LOG COMMAND...: in the background, pid appended to PIDS
  local n=$1 log=$2; shift 2
  in_ns "$n" "$@" >>"$WORK/$log.log" 2>&1 &
  PIDS+=("$!")
}
start opt discovery fastdds discovery -i 0 -l "${ADDR[opt]}" -p 11811
start opt optimizer "$BIN/cpgmatch-optimizer" "${DDS[@]}" --store "$WORK/s.db"
# Debug logs: every candidate a worker keeps and every report it writes (shown if the test fails).
start wa worker-wa "$BIN/cpgmatch-sim-worker" "${DDS[@]}" --id wa --slots 2 --log-level debug
start wb worker-wb "$BIN/cpgmatch-sim-worker" "${DDS[@]}" --id wb --slots 2 --log-level debug
WB_PID=${PIDS[-1]}

cat >"$WORK/s1.yaml" <<YAML
name: across-hosts
budget: 8
initial_points: 4
seed: 11
rollout: {entrain_s: 0.5, eval_s: 0.5}
YAML
# Study 2 is long enough (60 rollouts of 10 + 10 s, about 0.4 s of CPU each on 4 slots) that the link drop
# happens mid-study, with candidates on wb: the test checks that it did, not only that the study ends.
cat >"$WORK/s2.yaml" <<YAML
name: link-down
budget: 60
initial_points: 8
seed: 12
rollout: {entrain_s: 10, eval_s: 10}
YAML
submit() { in_ns opt "$BIN/cpgmatch" study submit --config "$1" "${DDS[@]}" --timeout 20 2>>"$WORK/cli.log"; }
view_state() {  # the read-only client in its own namespace
  in_ns view "$BIN/cpgmatch" status --study "$1" --json "${DDS[@]}" --timeout 10 2>>"$WORK/cli.log" || echo '{}'
}
field() { python3 -c 'import json,sys; v=json.loads(sys.argv[1]).get(sys.argv[2]); print("" if v is None else v)' "$1" "$2"; }
wait_for() {  # wait_for TIMEOUT_S COMMAND...
  local deadline=$((SECONDS + $1)); shift
  until "$@"; do ((SECONDS < deadline)) || return 1; sleep 0.3; done
}
study_done() { [[ $(field "$(view_state "$1")" state) == done ]]; }
completed_at_least() { [[ $(field "$(view_state "$1")" completed) -ge $2 ]] 2>/dev/null; }
log_has() { grep -q -- "$2" "$WORK/$1.log"; }

# Both worker hosts discovered (through the server) before study 1, whose 8 short rollouts take a fraction
# of a second: a worker joining a moment late would otherwise find it already done.
both_workers_seen() {
  local seen
  seen=$(in_ns view "$BIN/cpgmatch" workers --json "${DDS[@]}" --timeout 3 2>>"$WORK/cli.log" || true)
  [[ $seen == *'"wa"'* && $seen == *'"wb"'* ]]
}
wait_for 30 both_workers_seen || fail "the viewer does not see both worker hosts"
t0=$SECONDS
s1=$(submit "$WORK/s1.yaml") || fail "submit of study 1 across namespaces"
wait_for 40 study_done "$s1" || fail "study 1 did not finish: $(view_state "$s1")"
state=$(view_state "$s1")
[[ $(field "$state" completed) == 8 ]] || fail "study 1: $state"
echo "study 1 done across namespaces in $((SECONDS - t0)) s, seen from the viewer's namespace:" \
     "$(field "$state" completed)/$(field "$state" budget), best cost $(field "$state" best_cost), $(field "$state" workers) workers"
[[ $(sqlite3 "$WORK/s.db" "select count(distinct worker_id) from trials where study_id=$s1") == 2 ]] ||
  fail "both workers should have run rollouts of study 1"

# ---- a worker host drops off the network mid-study, then comes back -----------------------------------
s2=$(submit "$WORK/s2.yaml") || fail "submit of study 2"
wait_for 30 completed_at_least "$s2" 6 || fail "study 2 does not progress: $(view_state "$s2")"
joined_before=$(grep -c "worker wb joined" "$WORK/optimizer.log")
in_ns wb ip link set eth0 down
down_at=$SECONDS
at_down=$(field "$(view_state "$s2")" completed)
echo "wb link down at $at_down/60"
((at_down <= 50)) || fail "the link went down too late to test anything: $at_down/60 done"
wait_for 15 log_has optimizer "worker wb .*with" || fail "the optimizer did not notice that wb is gone"
held=$( (grep "worker wb .* with [0-9]* candidates assigned" "$WORK/optimizer.log" || true) | tail -1 |
       sed 's/.* with \([0-9]*\) candidates assigned.*/\1/')
((${held:-0} >= 1)) || fail "wb held no candidate when its link went down: $(grep "worker wb" "$WORK/optimizer.log" | tail -2)"
sleep 1
kill -0 "$WB_PID" 2>/dev/null || fail "worker wb died while its link was down"
in_ns wb ip link set eth0 up
echo "wb link up after $((SECONDS - down_at)) s, at $(field "$(view_state "$s2")" completed)/60"
wait_for 20 eval '[[ $(grep -c "worker wb joined" "$WORK/optimizer.log") -gt $joined_before ]]' ||
  fail "wb did not rejoin after its link came back"
unfinished() { sqlite3 "$WORK/s.db" "select group_concat('trial ' || trial_id || ' attempt ' || attempt || ' on ' || worker_id, '; ') from trials where study_id=$s2 and status != 'done'"; }
wait_for 60 study_done "$s2" || fail "study 2 did not finish: $(view_state "$s2"); in flight in the store: $(unfinished)"
state=$(view_state "$s2")
[[ $(field "$state" completed) == 60 ]] || fail "study 2 completed count: $state"
# Exactly once: 60 done trials, 60 distinct ids, and the optimizer counted 60 (its state says so).
read -r done distinct < <(sqlite3 -separator ' ' "$WORK/s.db" \
  "select count(*), count(distinct trial_id) from trials where study_id=$s2 and status='done'")
[[ $done == 60 && $distinct == 60 ]] || fail "study 2 store: $done done trials, $distinct distinct"
[[ $(sqlite3 "$WORK/s.db" "select count(*) from trials where study_id=$s2 and worker_id='wb' and issued_at > 0") -ge 1 ]] ||
  fail "wb never worked on study 2"
reissued=$(grep -c "study $s2 trial .*re-issuing" "$WORK/optimizer.log" || true)
((reissued >= held)) || fail "wb held $held candidates at the drop, but only $reissued were re-issued"
echo "PASS cluster across network namespaces (no multicast, discovery server): study 1 (8) and study 2 (60) done," \
     "wb's link down at $at_down/60 holding $held candidates and up again, $reissued re-issued," \
     "every trial counted once, $((SECONDS - t0)) s"
