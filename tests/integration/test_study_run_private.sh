#!/usr/bin/env bash
# `study run` is private by default: it makes a keystore for the run (a 0700 folder, removed at the end) and
# runs its optimizer, workers and client under DDS-Security, so a local process without its credentials
# (another user, or anything else on the machine: loopback is shared) reads no state or trial of it and
# cannot pause it. Control: the same probes do see and steer a study run with --insecure, which says so.
source "$(dirname "$0")/lib.sh"
cat >"$WORK/s.yaml" <<YAML
name: private
budget: 40
initial_points: 40
seed: 5
rollout: {entrain_s: 10, eval_s: 10}
YAML
before=$( (ls -d /tmp/cpgmatch-study-keys-* 2>/dev/null || true) | sort)
"$BIN/cpgmatch" study run --config "$WORK/s.yaml" --out "$WORK/secure" --domain "$DOMAIN" --workers 1 --jitter 0 \
  >"$WORK/secure-run.log" 2>&1 &
RUN_PID=$!; PIDS+=("$RUN_PID")
new_keys() { comm -13 <(echo "$before") <( (ls -d /tmp/cpgmatch-study-keys-* 2>/dev/null || true) | sort) | head -1 || true; }
have_new_keys() { [[ -n $(new_keys) ]]; }
wait_until 20 have_new_keys || fail "no private keystore was made: $(cat "$WORK/secure-run.log")"
keys=$(new_keys)
[[ $(stat -c %a "$keys") == 700 ]] || fail "the private keystore folder is $(stat -c %a "$keys"), not 700"
wait_until 30 grep -q "private keystore" "$WORK/secure-run.log" || fail "study run does not say it is secure"
wait_until 60 bash -c "[[ -f '$WORK/secure/study.db' ]] && [[ \$(sqlite3 '$WORK/secure/study.db' 'select count(*) from trials where status=\"done\"' 2>/dev/null) -ge 2 ]]" \
  || fail "the secure study does not progress: $(tail -5 "$WORK/secure-run.log")"

# An outsider on the same domain, without credentials: hears no optimizer, reads nothing, steers nothing.
outsider() { "$BIN/cpgmatch" "$@" --domain "$DOMAIN" --localhost-only --timeout 4 2>&1; }
seen=$(outsider status --json || true)
[[ $seen != *'"private"'* ]] || fail "an outsider read the private study's state: $seen"
paused=$(outsider study pause 1 || true)
[[ $paused != *"is paused"* ]] || fail "an outsider paused the private study: $paused"
wait "$RUN_PID" || fail "the private study run failed: $(tail -5 "$WORK/secure-run.log")"
[[ $(sqlite3 "$WORK/secure/study.db" "select state from studies where study_id=1") == done ]] || fail "the private study did not finish"
[[ -e $keys ]] && fail "the private keystore $keys was not removed"

# Control: the same outsider sees and steers an --insecure study (so the probes above could have succeeded).
sed -i 's/^name: .*/name: open-door/' "$WORK/s.yaml"
"$BIN/cpgmatch" study run --config "$WORK/s.yaml" --out "$WORK/insecure" --domain "$DOMAIN" --workers 1 --jitter 0 \
  --insecure >"$WORK/insecure-run.log" 2>&1 &
RUN_PID=$!; PIDS+=("$RUN_PID")
wait_until 20 grep -q "INSECURE (--insecure)" "$WORK/insecure-run.log" || fail "--insecure is not said aloud"
wait_until 30 bash -c "\"$BIN/cpgmatch\" status --json --domain $DOMAIN --localhost-only --timeout 3 2>/dev/null | grep -q open-door" \
  || fail "control: the outsider cannot read even an insecure study (the probe proves nothing)"
out=$(outsider study pause 1 || true)
[[ $out == *"is paused"* ]] || fail "control: the outsider could not pause the insecure study: $out"
outsider study resume 1 >/dev/null || true
wait "$RUN_PID" || true
echo "PASS study run private: keystore 0700 and removed; an outsider read no state and could not pause it" \
     "(control: the same outsider read and paused an --insecure study)"
