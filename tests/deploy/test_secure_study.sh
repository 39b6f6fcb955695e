#!/usr/bin/env bash
# DDS-Security end to end, with a keystore made by deploy/make-study-pki.sh: a study completes with every
# process authenticated and its topics encrypted; a participant without a certificate reads nothing and
# its injected reports never reach the optimizer; roles are enforced (a viewer reads but cannot submit, a
# worker identity cannot create the optimizer's writers); a missing file (crl.pem too), another enclave's
# permissions or an expired certificate stops a program with exit 2 naming the file. Prints the wall time of
# one study plain and secure.
#   BIN=build/bin DOMAIN=51 INJECT=build/bin/inject_malformed test_secure_study.sh
source "$(dirname "$0")/../integration/lib.sh"
INJECT=${INJECT:?INJECT must point at inject_malformed}
PKI="$(cd "$(dirname "$0")/../.." && pwd)/deploy/make-study-pki.sh"
KS=$WORK/keystore
"$PKI" "$KS" --days 2 >"$WORK/pki.log" 2>&1 || fail "make-study-pki.sh: $(cat "$WORK/pki.log")"
"$PKI" "$KS" --expired old-worker:worker >>"$WORK/pki.log" 2>&1 || fail "make-study-pki.sh --expired"
for f in public/ca.cert.pem enclaves/governance.p7s; do [[ -s $KS/$f ]] || fail "keystore lacks $f"; done
for e in optimizer worker operator viewer; do
  for f in identity_ca.cert.pem cert.pem key.pem crl.pem permissions_ca.cert.pem governance.p7s permissions.p7s; do
    [[ -s $KS/enclaves/$e/$f ]] || fail "enclave $e lacks $f"
  done
done

expect_exit() {  # expect_exit CODE TEXT COMMAND...: the command exits CODE and its stderr mentions TEXT
  local code=$1 text=$2 out rc; shift 2
  set +e; out=$("$@" 2>&1 >/dev/null); rc=$?; set -e
  [[ $rc == "$code" && $out == *"$text"* ]] || fail "expected exit $code mentioning '$text' from: $* -- got $rc: $out"
}

# ---- a broken keystore is refused before anything starts -------------------------------------------------
expect_exit 2 "old-worker/cert.pem has expired" "$BIN/cpgmatch-sim-worker" --domain "$DOMAIN" --localhost-only --keystore "$KS" --enclave old-worker
cp -r "$KS" "$WORK/broken" && rm "$WORK/broken/enclaves/worker/key.pem"
expect_exit 2 "enclaves/worker/key.pem is missing" "$BIN/cpgmatch-sim-worker" --domain "$DOMAIN" --localhost-only --keystore "$WORK/broken"
expect_exit 2 "--keystore" "$BIN/cpgmatch-optimizer" --domain "$DOMAIN" --localhost-only --keystore "$WORK/nowhere"
# Fail closed: without crl.pem revocation was silently off; another enclave's permissions.p7s exited 1 unnamed.
cp -r "$KS" "$WORK/no-crl" && rm "$WORK/no-crl/enclaves/worker/crl.pem"
expect_exit 2 "enclaves/worker/crl.pem is missing" "$BIN/cpgmatch-sim-worker" --domain "$DOMAIN" --localhost-only --keystore "$WORK/no-crl"
cp -r "$KS" "$WORK/swapped" && cp "$KS/enclaves/viewer/permissions.p7s" "$WORK/swapped/enclaves/worker/permissions.p7s"
expect_exit 2 "enclaves/worker/permissions.p7s grants 'CN=viewer'" "$BIN/cpgmatch-sim-worker" --domain "$DOMAIN" \
  --localhost-only --keystore "$WORK/swapped"

# ---- plain, then secure: the same study ------------------------------------------------------------------
write_study "$WORK/s.yaml" secure 24 8
run_study() {  # run_study TAG [security flags]: sets RUN_S (wall time of submit --wait) and RUN_OPT (optimizer pid)
  local tag=$1; shift
  "$BIN/cpgmatch-optimizer" --domain "$DOMAIN" --store "$WORK/$tag.db" --localhost-only "$@" >>"$WORK/optimizer-$tag.log" 2>&1 &
  local opt=$!; PIDS+=("$opt")
  "$BIN/cpgmatch-sim-worker" --domain "$DOMAIN" --id "worker/w-$tag" --slots 2 --localhost-only "$@" >>"$WORK/worker-$tag.log" 2>&1 &
  local w=$!; PIDS+=("$w")
  local t0; t0=$(date +%s.%N)
  "$BIN/cpgmatch" study submit --config "$WORK/s.yaml" --wait --quiet --json --domain "$DOMAIN" --localhost-only \
    --timeout 90 "$@" >"$WORK/$tag.json" 2>>"$WORK/cli.log" || fail "$tag study did not complete within 90 s: $(tail -n 3 "$WORK/cli.log")"
  RUN_S=$(python3 -c "import sys; print(f'{float(sys.argv[2]) - float(sys.argv[1]):.2f}')" "$t0" "$(date +%s.%N)")
  [[ $(json_field "$(cat "$WORK/$tag.json")" completed) == 24 ]] || fail "$tag study: $(cat "$WORK/$tag.json")"
  if [[ $tag == plain ]]; then kill -TERM "$opt" "$w"; wait "$opt" "$w" 2>/dev/null || true; fi
  RUN_OPT=$opt
}
run_study plain; plain_s=$RUN_S
run_study secure --keystore "$KS"; secure_s=$RUN_S; SECURE_OPT=$RUN_OPT
cli_secure() { "$BIN/cpgmatch" "$@" --domain "$DOMAIN" --localhost-only --timeout 15; }  # handshakes are slow on a loaded machine

# ---- who can see and do what -----------------------------------------------------------------------------
# Without a certificate: no optimizer is ever heard, so no state is read.
expect_exit 1 "no optimizer on DDS domain $DOMAIN" "$BIN/cpgmatch" status --domain "$DOMAIN" --localhost-only --timeout 4
# The viewer reads the state...
out=$(cli_secure status --study 1 --json --keystore "$KS" 2>>"$WORK/cli.log") || fail "the viewer cannot read the state"
[[ $(json_field "$out" state) == done ]] || fail "viewer read: $out"
# ...but may not submit: its permissions do not include the command topics.
expect_exit 1 "cpgmatch/replies" "$BIN/cpgmatch" study submit --config "$WORK/s.yaml" --domain "$DOMAIN" --localhost-only \
  --timeout 5 --keystore "$KS" --enclave viewer
# A worker identity cannot act as the optimizer (candidates, study state, trials, replies are not its to write).
expect_exit 1 "cannot create a writer on cpgmatch/candidates" "$BIN/cpgmatch-optimizer" --domain "$DOMAIN" --localhost-only \
  --store "$WORK/impostor.db" --keystore "$KS" --enclave worker
# An injector without a certificate never matches the secure optimizer: its forged reports go nowhere.
expect_exit 1 "nobody to talk to" "$INJECT" "$DOMAIN" 1 worker/w-secure
[[ $(sql "$WORK/secure.db" "select count(*) from studies") == 1 ]] || fail "a study was created by someone"
grep -q "injector\|impostor" "$WORK/optimizer-secure.log" && fail "the secure optimizer heard the injector"
kill -0 "$SECURE_OPT" || fail "the secure optimizer died"
# With $CPGMATCH_KEYSTORE exported, `study run` and the services it starts all join securely.
write_study "$WORK/tiny.yaml" tiny 3 2
CPGMATCH_KEYSTORE=$KS "$BIN/cpgmatch" study run --config "$WORK/tiny.yaml" --workers 1 --out "$WORK/run" --jitter 0 \
  >/dev/null 2>"$WORK/study-run.log" || fail "study run with CPGMATCH_KEYSTORE: $(tail -n 3 "$WORK/study-run.log")"
[[ $(sql "$WORK/run/study.db" "select count(*) from trials where status='done'") == 3 ]] || fail "secure study run: not 3 trials"
echo "PASS DDS-Security: secure study of 24 done; no-certificate reader and injector hear nothing; viewer reads," \
     "cannot submit; worker identity cannot write optimizer topics; expired, incomplete (no key, no CRL) and" \
     "swapped-permissions keystores exit 2 naming the file;" \
     "study run with CPGMATCH_KEYSTORE works." \
     "Wall time of the same study (2 slots, 0.5+0.5 s rollouts): plain ${plain_s} s, secure ${secure_s} s"
