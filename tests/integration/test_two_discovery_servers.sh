#!/usr/bin/env bash
# Two discovery servers, one killed mid-study: nothing is lost and the study completes through the other.
# Every process is a client of both servers (the shipped `cluster` profile, --discovery-server "A;B").
# Server 0 is killed with SIGKILL while the study runs; then a new worker joins and the first one is
# killed, so that the rest of the study runs on a worker that could only have found the optimizer
# through server 1; a client started after the kill still reads the study. The study ends with every
# trial done exactly once, and the new worker did some of them.
source "$(dirname "$0")/lib.sh"
start_discovery_server 0; DS0_PID=$DS_PID; DS0_PORT=$DS_PORT
start_discovery_server 1; DS1_PORT=$DS_PORT
CLUSTER=(--domain "$DOMAIN" --dds-profile cluster --discovery-server "127.0.0.1:$DS0_PORT;127.0.0.1:$DS1_PORT")
ccli() { "$BIN/cpgmatch" "$@" "${CLUSTER[@]}" 2>>"$WORK/cli.log"; }
cstate() { ccli status --study "$1" --json --timeout 5 2>/dev/null || echo '{}'; }
cdone_at_least() { [[ $(json_field "$(cstate "$1")" completed) -ge $2 ]] 2>/dev/null; }
cstudy_is() { [[ $(json_field "$(cstate "$1")" state) == "$2" ]]; }

"$BIN/cpgmatch-optimizer" "${CLUSTER[@]}" --store "$WORK/s.db" >>"$WORK/optimizer.log" 2>&1 &
PIDS+=("$!")
"$BIN/cpgmatch-sim-worker" "${CLUSTER[@]}" --id first --slots 2 --fake-rollout-ms 400 >>"$WORK/worker-first.log" 2>&1 &
FIRST=$!; PIDS+=("$FIRST")
write_study "$WORK/s.yaml" two-servers 40
id=$(ccli study submit --config "$WORK/s.yaml" --timeout 30) || fail "submit failed"
wait_until 60 cdone_at_least "$id" 4 || fail "the study did not start"

kill -9 "$DS0_PID"; wait "$DS0_PID" 2>/dev/null || true
kill -0 "$DS0_PID" 2>/dev/null && fail "discovery server 0 is still running"
before=$(sql "$WORK/s.db" "select count(*) from trials where status='done'")
((before < 40)) || fail "the study ended before server 0 was killed; the test proves nothing"

# A worker that joins now can only be introduced to the optimizer by server 1.
"$BIN/cpgmatch-sim-worker" "${CLUSTER[@]}" --id second --slots 2 --fake-rollout-ms 400 >>"$WORK/worker-second.log" 2>&1 &
PIDS+=("$!")
listed_second() { [[ $(ccli workers --json --timeout 5) == *'"second"'* ]]; }
wait_until 60 listed_second || fail "the worker started after server 0 died was never listed"
kill -9 "$FIRST"; wait "$FIRST" 2>/dev/null || true
at_kill=$(sql "$WORK/s.db" "select count(*) from trials where status='done'")
((at_kill < 40)) || fail "the study ended before the first worker was killed; the test proves nothing"

wait_until 120 cstudy_is "$id" done || fail "the study did not finish through server 1"
out=$(cstate "$id")
[[ $(json_field "$out" completed) == 40 ]] || fail "completed: $out"
[[ $(sql "$WORK/s.db" "select count(*) from trials where status='done'") == 40 ]] || fail "store: not 40 done trials"
[[ $(sql "$WORK/s.db" "select count(*) from trials") == 40 ]] || fail "store: more trials than the budget"
by_second=$(sql "$WORK/s.db" "select count(*) from trials where status='done' and worker_id='second'")
((by_second >= 1)) || fail "no trial was done by the worker that joined through server 1"
echo "PASS two discovery servers: server 0 killed at $before of 40 done, first worker killed at $at_kill," \
     "$by_second trials done by the worker that joined through server 1: $out"
