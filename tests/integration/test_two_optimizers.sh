#!/usr/bin/env bash
# Two optimizers on one domain (each with its own store) notice each other and say so in their logs.
source "$(dirname "$0")/lib.sh"
"$BIN/cpgmatch-optimizer" --domain "$DOMAIN" --store "$WORK/a.db" --localhost-only >"$WORK/a.log" 2>&1 &
PIDS+=($!)
"$BIN/cpgmatch-optimizer" --domain "$DOMAIN" --store "$WORK/b.db" --localhost-only >"$WORK/b.log" 2>&1 &
PIDS+=($!)
both_said_so() { grep -q "another cpgmatch-optimizer joined" "$WORK/a.log" && grep -q "another cpgmatch-optimizer joined" "$WORK/b.log"; }
wait_until 20 both_said_so || fail "the optimizers did not report each other: $(cat "$WORK/a.log" "$WORK/b.log" | tail -5)"
echo "PASS two optimizers on domain $DOMAIN: both logged the other"
