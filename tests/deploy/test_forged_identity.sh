#!/usr/bin/env bash
# DDS-Security binds a worker id to a certificate: a participant with a valid worker certificate for
# identity "mallory" (make-study-pki.sh mallory:worker) reads the candidates sent to the honest worker
# "worker" and answers each at once as "worker" with cost 1e-6, announces itself as "worker" too and
# disposes worker's announcement (which would drop the honest worker).
# None of it counts (the optimizer refuses every such sample, naming mallory's CN), and the study completes
# through the honest worker with its real costs. Mallory also announces 16 slots as itself and never answers:
# after its first lease expires it is on probation and holds at most one candidate at a time (2 allowed for
# the two clocks). A worker started with an --id its certificate does not own exits 2. Then mallory is
# revoked (make-study-pki.sh KEYSTORE revoke mallory): restarted with the new CRL, the optimizer never hears
# mallory (who kept its old enclave), and mallory's refreshed enclave exits 2 naming the revocation.
#   BIN=build/bin DOMAIN=60 ROGUE=build/tests/rogue_worker test_forged_identity.sh
source "$(dirname "$0")/../integration/lib.sh"
ROGUE=${ROGUE:?ROGUE must point at rogue_worker}
PKI="$(cd "$(dirname "$0")/../.." && pwd)/deploy/make-study-pki.sh"
KS=$WORK/keystore
"$PKI" "$KS" --days 2 optimizer:optimizer worker:worker operator:operator mallory:worker >"$WORK/pki.log" 2>&1 ||
  fail "make-study-pki.sh: $(cat "$WORK/pki.log")"

# A worker id the certificate does not own is refused before anything starts.
set +e; out=$("$BIN/cpgmatch-sim-worker" --domain "$DOMAIN" --localhost-only --keystore "$KS" --id intruder 2>&1); rc=$?; set -e
[[ $rc == 2 && $out == *"--id 'intruder'"*"'worker'"* ]] || fail "--id intruder under the worker certificate: exit $rc: $out"

write_study "$WORK/s.yaml" forged 16 16
echo "lease_s: 3" >>"$WORK/s.yaml"  # a lease that expires within the test
S=(--domain "$DOMAIN" --localhost-only --keystore "$KS")
start_optimizer "$WORK/s.db" --keystore "$KS"
# No --id: under a keystore the worker id is the certificate's CN, "worker".
"$BIN/cpgmatch-sim-worker" "${S[@]}" --slots 2 >>"$WORK/worker.log" 2>&1 &
HONEST_PID=$!; PIDS+=("$HONEST_PID")
"$ROGUE" "$DOMAIN" "$KS" mallory mallory 16 worker 120 >"$WORK/rogue.out" 2>"$WORK/rogue.log" &
ROGUE_PID=$!; PIDS+=("$ROGUE_PID")
# Both must be known before the study starts, so that mallory takes its share of the first candidates.
wait_until 30 grep -q "worker worker joined" "$WORK/optimizer.log" || fail "the honest worker never joined"
wait_until 30 grep -q "worker mallory joined" "$WORK/optimizer.log" || fail "mallory never joined"
out=$("$BIN/cpgmatch" study submit --config "$WORK/s.yaml" --wait --json --quiet --timeout 90 "${S[@]}" 2>>"$WORK/cli.log") ||
  fail "the study did not complete: $out"
[[ $(json_field "$out" completed) == 16 ]] || fail "study: $out"
kill -TERM "$ROGUE_PID"; wait "$ROGUE_PID" || fail "rogue_worker exited $?"
rogue=$(cat "$WORK/rogue.out")
forged=$(sed -n 's/^forged \([0-9]*\);.*/\1/p' <<<"$rogue")
own=$(sed -n 's/.*own candidates \([0-9]*\);.*/\1/p' <<<"$rogue")
held=$(sed -n 's/.*lease expired \([0-9]*\)$/\1/p' <<<"$rogue")
[[ -n $forged && $forged -ge 1 ]] || fail "mallory forged no report (nothing tested): $rogue"
# Not one forged report counted: every counted report is the honest worker's, none has mallory's cost.
[[ $(sql "$WORK/s.db" "select count(*) from trials where status='done'") == 16 ]] || fail "not 16 done trials"
# Only reports that ran (ok) can be forged ones: a rollout that failed (killed at its timeout on a loaded
# machine) is stored with ok = false and cost 0.
forged_counted() { sql "$1" "select count(*) from trials where status='done' and json_extract(report_json,'\$.ok') and cost < 0.001"; }
[[ $(forged_counted "$WORK/s.db") == 0 ]] ||
  fail "a forged report (cost 1e-6) was counted"
# Every counted rollout that ran took time (mallory answers at once); a rollout that failed (ok = false:
# killed at its 3-s timeout on a loaded machine, seen in CI) is the honest worker's and did not run to the end.
[[ $(sql "$WORK/s.db" "select count(*) from trials where status='done' and json_extract(report_json,'\$.ok') and coalesce(json_extract(report_json,'\$.wall_time_s'), 0) <= 0") == 0 ]] ||
  fail "a counted report did not come from a real rollout"
refused=$(grep -c "rejected report for study 1 trial [0-9]* from worker: the sender's certificate is CN=mallory" "$WORK/optimizer.log" || true)
[[ $refused -ge 1 ]] || fail "no forged report was refused by name"
grep -q "rejected worker announcement worker: the sender's certificate is CN=mallory" "$WORK/optimizer.log" ||
  fail "mallory's announcement as worker was not refused"
grep -q "rejected dispose of worker worker: the sender's certificate is CN=mallory" "$WORK/optimizer.log" ||
  fail "mallory's dispose of worker's announcement was not refused"
grep -q "worker worker left the domain" "$WORK/optimizer.log" && fail "mallory's dispose dropped the honest worker"
# A slot count is a claim: after its first lease expired mallory held one candidate at a time.
[[ -n $own && $own -ge 2 ]] || fail "mallory took fewer than 2 candidates (probation not exercised): $rogue"
grep -q "worker mallory on probation" "$WORK/optimizer.log" || fail "mallory was never put on probation"
[[ -n $held && $held -le 2 ]] || fail "mallory held $held candidates at once after a lease expired (16 slots announced)"
kill -0 "$OPT_PID" || fail "the optimizer died"

# ---- revocation: make-study-pki.sh KEYSTORE revoke mallory ---------------------------------------------------
# Mallory keeps its enclave as it was (with the CRL of before); every other participant gets the new CRL.
cp -r "$KS" "$WORK/mallory-copy"
"$PKI" "$KS" revoke mallory >>"$WORK/pki.log" 2>&1 || fail "make-study-pki.sh revoke: $(tail -n 3 "$WORK/pki.log")"
for e in optimizer worker operator mallory; do
  cmp -s "$KS/public/crl.pem" "$KS/enclaves/$e/crl.pem" || fail "enclave $e did not get the new CRL"
done
# The refreshed enclave says so itself, before anything starts.
set +e; out=$("$BIN/cpgmatch-sim-worker" --domain "$DOMAIN" --localhost-only --keystore "$KS" --enclave mallory 2>&1); rc=$?; set -e
[[ $rc == 2 && $out == *"mallory/cert.pem has been revoked"* ]] || fail "the revoked enclave: exit $rc: $out"
# The services restart with the new CRL (a participant reads it when it starts); mallory comes back with its copy.
kill -TERM "$OPT_PID" "$HONEST_PID"; wait "$OPT_PID" "$HONEST_PID" 2>/dev/null || true
"$BIN/cpgmatch-optimizer" --domain "$DOMAIN" --store "$WORK/revoked.db" --localhost-only --keystore "$KS" \
  >>"$WORK/optimizer-revoked.log" 2>&1 &
OPT_PID=$!; PIDS+=("$OPT_PID")
"$ROGUE" "$DOMAIN" "$WORK/mallory-copy" mallory mallory 16 worker 15 >"$WORK/rogue-revoked.out" 2>"$WORK/rogue-revoked.log" &
ROGUE_PID=$!; PIDS+=("$ROGUE_PID")
"$BIN/cpgmatch-sim-worker" "${S[@]}" --slots 2 >>"$WORK/worker-revoked.log" 2>&1 &
HONEST_PID=$!; PIDS+=("$HONEST_PID")
wait_until 30 grep -q "worker worker joined" "$WORK/optimizer-revoked.log" || fail "the honest worker never joined after the revocation"
sed -i 's/^budget: 16/budget: 4/; s/^initial_points: 16/initial_points: 4/' "$WORK/s.yaml"
out=$("$BIN/cpgmatch" study submit --config "$WORK/s.yaml" --wait --json --quiet --timeout 60 "${S[@]}" 2>>"$WORK/cli.log") ||
  fail "the study after the revocation did not complete: $out"
[[ $(json_field "$out" completed) == 4 ]] || fail "study after the revocation: $out"
wait "$ROGUE_PID" || fail "rogue_worker (revoked) exited $?"
revoked=$(cat "$WORK/rogue-revoked.out")
[[ $revoked == "forged 0; own candidates 0;"* ]] || fail "the revoked mallory still received candidates: $revoked"
grep -q "worker mallory joined\|CN=mallory" "$WORK/optimizer-revoked.log" && fail "the optimizer heard the revoked mallory"
[[ $(forged_counted "$WORK/revoked.db") == 0 ]] || fail "a forged report counted"
echo "PASS forged identity: $forged reports forged by mallory as 'worker', $refused refused by name, none counted;" \
     "16 trials from the honest worker; mallory (16 slots, never answers) took $own candidates, at most $held at" \
     "once after its first lease expired; --id outside the certificate exits 2; after make-study-pki.sh revoke" \
     "mallory (with its old enclave) is never heard and its refreshed enclave exits 2"
