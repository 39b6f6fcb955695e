#!/usr/bin/env bash
# A worker that hears no optimizer rebuilds its DDS participant by itself, says so, and keeps trying with a
# jittered wait; the rebuilt participant then serves a study once an optimizer comes. (The rebuild is what
# recovers a worker whose discovery went wrong: a discovery server that lost it, ports taken on a crowded
# host; here the silence is simply no optimizer yet, which takes the same path.)
source "$(dirname "$0")/lib.sh"
# Nothing on the domain yet: `workers` prints an empty list and says on stderr that it heard nothing.
listed=$("$BIN/cpgmatch" workers --json --domain "$DOMAIN" --localhost-only --timeout 2 2>"$WORK/workers-empty.err") ||
  fail "workers failed on an empty domain"
[[ $listed == '[]' ]] || fail "workers on an empty domain listed: $listed"
grep -q "no worker heard on DDS domain $DOMAIN" "$WORK/workers-empty.err" ||
  fail "workers did not say it heard nothing: $(cat "$WORK/workers-empty.err")"
start_worker lonely --slots 2 --fake-rollout-ms 200
said_rebuild() { grep -q "rebuilding its DDS participant (attempt 1;" "$WORK/worker-lonely.log"; }
# The first rebuild comes after 15 to 45 s of silence (30 s times a random factor in [0.5, 1.5)).
wait_until 70 said_rebuild || fail "the worker never said it rebuilt its participant"
grep -q "no optimizer on DDS domain $DOMAIN" "$WORK/worker-lonely.log" || fail "the worker never said what it missed"
start_optimizer "$WORK/s.db"
"$BIN/cpgmatch" status --domain "$DOMAIN" --localhost-only --timeout 10 >/dev/null 2>"$WORK/status-empty.err" ||
  fail "status failed: $(cat "$WORK/status-empty.err")"
grep -q "has no study" "$WORK/status-empty.err" || fail "status did not say the optimizer has no study"
write_study "$WORK/s.yaml" after-rejoin 8
id=$(cli study submit --config "$WORK/s.yaml" --timeout 30) || fail "submit failed"
wait_until 60 study_is "$id" done || fail "the study did not finish on the rebuilt worker"
[[ $(sql "$WORK/s.db" "select count(*) from trials where status='done' and worker_id='lonely'") == 8 ]] ||
  fail "store: not 8 trials done by the worker"
grep -q "an optimizer is on domain $DOMAIN now (after [0-9]* rebuilds" "$WORK/worker-lonely.log" ||
  fail "the worker did not say it found the optimizer after rebuilding"
echo "PASS worker rejoins: $(grep -c 'rebuilding its DDS participant' "$WORK/worker-lonely.log") rebuilds," \
     "then 8 of 8 trials done"
