#!/usr/bin/env bash
# A store the optimizer cannot write is refused at start, plainly: exit 2, a message naming the store and
# saying it is read-only, and the store unchanged (its finished study still there, still readable).
# As root, file modes do not stop writes, so the optimizer then runs as `nobody` (setpriv) on a store
# owned by root; as any other user the store is simply made read-only with chmod.
source "$(dirname "$0")/lib.sh"
write_study "$WORK/s.yaml" readonly-store 4 4
start_optimizer "$WORK/s.db"
start_worker w --slots 2 --fake-rollout-ms 10
id=$(cli study submit --config "$WORK/s.yaml" --timeout 20) || fail "submit failed"
wait_until 60 study_is "$id" done || fail "the study did not finish"
kill "$OPT_PID"
wait "$OPT_PID" 2>/dev/null || true
before=$(sql "$WORK/s.db" "select count(*) || ' ' || group_concat(cost) from trials where status = 'done'")

chmod 0444 "$WORK/s.db"
chmod 0755 "$WORK"
chmod 0666 "$WORK/s.db.lock"  # the lock file is not what this test is about
as_user=()
if [[ $(id -u) == 0 ]]; then
  command -v setpriv >/dev/null || fail "setpriv (util-linux) is needed to run the optimizer as nobody"
  as_user=(setpriv --reuid=65534 --regid=65534 --clear-groups)
fi
set +e
timeout 30 "${as_user[@]}" "$BIN/cpgmatch-optimizer" --domain "$DOMAIN" --store "$WORK/s.db" --localhost-only \
  >"$WORK/readonly.log" 2>&1
code=$?
set -e
[[ $code == 2 ]] || fail "expected exit 2 on a read-only store, got $code: $(cat "$WORK/readonly.log")"
grep -q "$WORK/s.db" "$WORK/readonly.log" || fail "the message does not name the store: $(cat "$WORK/readonly.log")"
grep -qi "read-only" "$WORK/readonly.log" || fail "the message does not say read-only: $(cat "$WORK/readonly.log")"
after=$(sql "$WORK/s.db" "select count(*) || ' ' || group_concat(cost) from trials where status = 'done'")
[[ $after == "$before" ]] || fail "the store changed: '$before' -> '$after'"
echo "PASS read-only store: exit 2, $(grep -m1 -o 'error: .*' "$WORK/readonly.log")"
