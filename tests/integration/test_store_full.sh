#!/usr/bin/env bash
# Disk full, as a file-size limit the store's files hit (ulimit -f 384: room for the study with its spec,
# about 10 kB twice over with the WAL, and 30-40 results): the optimizer stops with exit 1 and
# a message naming the store and the cause, and loses nothing: restarted without the limit on the same
# store, the study completes with exactly its budget of results.
source "$(dirname "$0")/lib.sh"
write_study "$WORK/s.yaml" store-full 400 400
(ulimit -f 384; exec "$BIN/cpgmatch-optimizer" --domain "$DOMAIN" --store "$WORK/s.db" --localhost-only \
   --log-level warn) >"$WORK/optimizer-full.log" 2>&1 &
full_pid=$!
PIDS+=("$full_pid")
start_worker w --slots 8 --fake-rollout-ms 1
cli study submit --config "$WORK/s.yaml" --timeout 20 >/dev/null || fail "submit failed"
gone() { ! kill -0 "$full_pid" 2>/dev/null; }
wait_until 60 gone || fail "the optimizer kept running with its store at the size limit"
set +e
wait "$full_pid"
code=$?
set -e
[[ $code == 1 ]] || fail "expected exit 1 when the store cannot be written, got $code: $(tail -3 "$WORK/optimizer-full.log")"
grep -q "study store $WORK/s.db: cannot write" "$WORK/optimizer-full.log" ||
  fail "the message does not name the store and say it cannot write: $(tail -3 "$WORK/optimizer-full.log")"
counted=$(sql "$WORK/s.db" "select count(*) from trials where status = 'done'")
start_optimizer "$WORK/s.db"
wait_until 90 study_is 1 done || fail "after the restart the study did not finish: $(state_json 1)"
[[ $(sql "$WORK/s.db" "select count(*) from trials where status = 'done'") == 400 ]] || fail "not exactly 400 results"
[[ $(sql "$WORK/s.db" "select count(*) from trials") == 400 ]] || fail "trials beyond the budget"
[[ $(sql "$WORK/s.db" "pragma integrity_check") == ok ]] || fail "store integrity"
echo "PASS store full: exit 1 after $counted results ($(grep -m1 -o 'study store .*' "$WORK/optimizer-full.log" | cut -c1-120)); restarted: 400 results"
