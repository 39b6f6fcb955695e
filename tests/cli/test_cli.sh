#!/usr/bin/env bash
# Command-line behaviour: exit codes, error messages naming the field/file/line, JSON fields, traces,
# a failing objective that does not stop a run. Prints 'N passed, N failed' and exits non-zero on failure.
set -u
bin="$1"
source "$(dirname "$0")/cli_lib.sh"

# Bad input: exit 2 and a message naming the field (and file:line for YAML).
check "did you mean status" expect_exit 2 "unknown command 'statsu'; did you mean 'cpgmatch status'?" "$bin" statsu
check "did you mean study submit" expect_exit 2 "did you mean 'cpgmatch study submit'?" "$bin" study sumbit --config x.yaml
check "an unrelated word lists the commands" expect_exit 2 "its commands are: .*export" "$bin" frobnicate
"$bin" rollout --help >"$tmp/rollout-help.txt"
check "rollout --help lists every terrain" sh -c "for t in flat step:HEIGHT@DISTANCE rough:AMPLITUDE shift:HEIGHT@TIME; do grep -q \"\$t\" '$tmp/rollout-help.txt' || exit 1; done"
check "unknown parameter" expect_exit 2 "hip_ofset" "$bin" rollout --set hip_ofset=0.1
check "out of range" expect_exit 2 "duty_factor_front" "$bin" rollout --set duty_factor_front=0.95
check "nan value" expect_exit 2 "finite" "$bin" rollout --set overswing=nan
check "bad terrain" expect_exit 2 "terrain" "$bin" rollout --terrain hills
check "entrain too long" expect_exit 2 "\-\-entrain" "$bin" rollout --entrain 1e12
check "eval nan" expect_exit 2 "\-\-eval" "$bin" rollout --eval nan
check "eval negative" expect_exit 2 "\-\-eval" "$bin" rollout --eval -1
check "treadmill nan" expect_exit 2 "\-\-treadmill" "$bin" rollout --treadmill nan
check "seed negative" expect_exit 2 "\-\-seed" "$bin" rollout --seed -1
printf 'hip_offset: 0.1\nduty_factor_hind: [1, 2]\n' >"$tmp/p.yaml"
check "malformed params file names file:line" expect_exit 2 "p.yaml:2" "$bin" rollout --params "$tmp/p.yaml"
printf 'hip_offset: 0.1\n  bad: : indent\n' >"$tmp/broken.yaml"
check "yaml syntax error names file" expect_exit 2 "broken.yaml" "$bin" rollout --params "$tmp/broken.yaml"
printf 'parameters:\n  - {name: x, low: 2, high: 1}\n' >"$tmp/space.yaml"
check "low >= high" expect_exit 2 "space.yaml:2" "$bin" optimize --space "$tmp/space.yaml" --objective-cmd "echo 1" --budget 2
check "missing objective" expect_exit 2 "objective" "$bin" optimize --space "$tmp/space.yaml" --budget 2
printf 'name: s\nbudget: 0\n' >"$tmp/study.yaml"
check "bad study budget" expect_exit 2 "budget" "$bin" study run --config "$tmp/study.yaml" --out "$tmp/s"
# YAML that yaml-cpp read silently as something else: a second document, an unclosed quote. A study file is
# checked before anything starts (submit: before an optimizer is looked for; reproduce: before its first run).
printf 'name: s\nbudget: 6\n---\nbudget: 600\n' >"$tmp/two-docs.yaml"
check "second YAML document names file:line" expect_exit 2 "two-docs.yaml:3: a second YAML document" \
  "$bin" study submit --config "$tmp/two-docs.yaml" --domain 90 --localhost-only --timeout 1
printf 'name: s\n...\nbudget: 600\n' >"$tmp/after-end.yaml"
check "content after ... names file:line" expect_exit 2 "after-end.yaml:3: a second YAML document" \
  "$bin" reproduce --config "$tmp/after-end.yaml" --out "$tmp/r-after-end" --seeds 1
printf 'name: "s\nbudget: 6\n' >"$tmp/open-quote.yaml"
check "unclosed quote names file:line" expect_exit 2 "open-quote.yaml:1: malformed YAML: a quoted string" \
  "$bin" study submit --config "$tmp/open-quote.yaml" --domain 90 --localhost-only --timeout 1
check "unclosed quote, reproduce" expect_exit 2 "open-quote.yaml:1" "$bin" reproduce --config "$tmp/open-quote.yaml" \
  --out "$tmp/r-open-quote" --seeds 1
python3 -c "print('name: big'); print('# ' + 'x' * (1 << 20))" >"$tmp/big.yaml"
check "a study file over 1 MiB" expect_exit 2 "big.yaml: larger than 1 MiB" "$bin" study run --config "$tmp/big.yaml" --out "$tmp/s"

# rollout --json: exactly one JSON object with the documented fields; the trace is written.
"$bin" rollout --params "$(dirname "$0")/../../configs/params/matched-trot.yaml" --entrain 1 --eval 2 --json --trace "$tmp/t.csv" >"$tmp/r.json"
check "rollout json fields" python3 -c "
import json,sys
r=json.load(open('$tmp/r.json'))
need=['cost','terms','normalized_torque','fell','distance_m','mean_speed_mps','feedback_fraction','sim_time_s','wall_time_s','params']
assert all(k in r for k in need), [k for k in need if k not in r]
assert set(r['terms'])>={'feedback','distance','pitch','contact','periodicity'}
assert set(r['feedback_fraction'])=={'late_touchdown','early_touchdown','early_toeoff','late_toeoff'}
assert abs(r['sim_time_s']-3.0)<0.01
"
check "rollout prints one line" test "$(wc -l <"$tmp/r.json")" -eq 1
check "trace has rows" test "$(wc -l <"$tmp/t.csv")" -gt 1000

# optimize: a failing objective is logged and the run continues; the result has the best point.
printf 'parameters:\n  - {name: x, low: -2, high: 3}\n' >"$tmp/q.yaml"
cat >"$tmp/obj.sh" <<'OBJ'
#!/bin/sh
x=$(python3 -c 'import json,sys; print(json.load(sys.stdin)["x"])')
case "$x" in -1.*) exit 3;; esac
python3 -c "print(($x-0.7)**2)"
OBJ
chmod +x "$tmp/obj.sh"
"$bin" optimize --space "$tmp/q.yaml" --objective-cmd "$tmp/obj.sh" --budget 14 --initial 5 --seed 3 --json >"$tmp/o.json" 2>"$tmp/o.err"
check "optimize finishes and finds the quadratic minimum" python3 -c "
import json; r=json.load(open('$tmp/o.json')); assert r['evaluations']==14, r; assert r['best'] < 1e-2, r['best']"
"$bin" optimize --space "$tmp/q.yaml" --objective-cmd "echo notanumber" --budget 3 --initial 2 --json >"$tmp/f.json" 2>"$tmp/f.err"
check "non-number output is a failed evaluation, not a crash" python3 -c "
import json; r=json.load(open('$tmp/f.json')); assert r['failed']==3 and r['evaluations']==3, r"
check "failure is logged" grep -q "not a finite number" "$tmp/f.err"
check "every evaluation failed: exit 1, saying so" expect_exit 1 "every evaluation failed (3 of 3)" \
  "$bin" optimize --space "$tmp/q.yaml" --objective-cmd "echo notanumber" --budget 3 --initial 2 --quiet
# Seeds are whole numbers in [0, 2^64 - 1]: -1 and a longer number both ran as seed 2^64 - 1.
check "optimize seed negative" expect_exit 2 "\-\-seed" "$bin" optimize --space "$tmp/q.yaml" --objective-cmd "echo 1" --budget 2 --seed -1
check "optimize seed overflow" expect_exit 2 "\-\-seed" "$bin" optimize --space "$tmp/q.yaml" --objective-cmd "echo 1" --budget 2 \
  --seed 18446744073709551616
check "rollout seed overflow" expect_exit 2 "\-\-seed" "$bin" rollout --seed 99999999999999999999
check "optimize initial beyond budget" expect_exit 2 "\-\-initial 100 is more than \-\-budget 6" \
  "$bin" optimize --space "$tmp/q.yaml" --objective-cmd "echo 1" --budget 6 --initial 100
check "optimize default initial with a small budget" \
  sh -c '"$0" optimize --space "$1" --objective-cmd "echo 1" --budget 2 --quiet >/dev/null' "$bin" "$tmp/q.yaml"
# A log-transformed objective returning a cost <= 0: that evaluation failed (named, with its cost), the run goes on.
cat >"$tmp/signed.sh" <<'OBJ'
#!/bin/sh
python3 -c 'import json,sys; print(json.load(sys.stdin)["x"])'
OBJ
chmod +x "$tmp/signed.sh"
"$bin" optimize --space "$tmp/q.yaml" --objective-cmd "$tmp/signed.sh" --cost-transform log --budget 8 --initial 6 --seed 1 \
  --json >"$tmp/log.json" 2>"$tmp/log.err"
check "log transform: a cost <= 0 is a failed evaluation, not bad input" test $? -eq 0
check "log transform: the run went on, positive costs counted" python3 -c "
import json; r=json.load(open('$tmp/log.json')); t=r['trials']
assert r['evaluations']==8 and 0 < r['failed'] < 8, r
assert all((x['ok'] and x['params']['x'] > 0) or (not x['ok'] and x['params']['x'] <= 0) for x in t), t
assert all('is not > 0' in x['error'] for x in t if not x['ok']), t"
check "log transform: the warning names the cost" grep -q "evaluation [0-9]* failed: cost -[0-9.]* is not > 0" "$tmp/log.err"

# bench-optimizer prints the documented fields.
"$bin" bench-optimizer --function branin --budget 20 --initial 5 --seed 0 --quiet --json >"$tmp/b.json"
check "bench-optimizer json" python3 -c "
import json; r=json.load(open('$tmp/b.json')); assert {'best','regret','best_index','wall_time_s','proposal_ms_last'} <= set(r)"

# A log-modelled cost on a function that is not > 0 everywhere is refused before the run, not mid-run.
check "bench-optimizer log on hartmann3" expect_exit 2 "\-\-cost-transform log: hartmann3" \
  "$bin" bench-optimizer --function hartmann3 --cost-transform log --budget 10 --quiet
"$bin" bench-optimizer --function branin --cost-transform log --budget 12 --initial 5 --seed 0 --quiet --json >"$tmp/bl.json"
check "bench-optimizer log on branin (minimum 0.398 > 0) runs" test $? -eq 0

# The service executables and clients: bad flags and environment exit 2 naming them; no optimizer is
# a clear failure (exit 1), not a hang.
bindir="$(dirname "$bin")"
check "worker --slots 0" expect_exit 2 "\-\-slots" "$bindir/cpgmatch-sim-worker" --slots 0
check "worker --id too long" expect_exit 2 "\-\-id" "$bindir/cpgmatch-sim-worker" --id "$(printf 'w%.0s' {1..80})"
check "optimizer --domain 999" expect_exit 2 "domain" "$bindir/cpgmatch-optimizer" --domain 999 --store "$tmp/x.db"
"$bindir/cpgmatch-optimizer" --domain 94 --store "$tmp/locked.db" --localhost-only >"$tmp/first.log" 2>&1 &
first=$!
# The lock file exists a moment before it is locked; its holder's pid is written only once it is held.
for _ in $(seq 50); do [ -s "$tmp/locked.db.lock" ] && break; sleep 0.1; done
check "second optimizer on one store" expect_exit 2 "already in use" "$bindir/cpgmatch-optimizer" --domain 95 --store "$tmp/locked.db"
kill "$first"; wait "$first" 2>/dev/null
check "store created 0600" test "$(stat -c %a "$tmp/locked.db")" = 600
check "optimizer bad --log-level" expect_exit 2 "log-level" "$bindir/cpgmatch-optimizer" --log-level loud
check "CPGMATCH_DOMAIN not a number" expect_exit 2 "CPGMATCH_DOMAIN" env CPGMATCH_DOMAIN=abc "$bin" status
check "submit a missing file" expect_exit 2 "nope.yaml" "$bin" study submit --config "$tmp/nope.yaml" --domain 90
check "status without an optimizer" expect_exit 1 "no optimizer" "$bin" status --domain 90 --localhost-only --timeout 1
check "status --study without an optimizer: exit 1, not bad input" expect_exit 1 "no optimizer on DDS domain 90 (none heard within 1 s)" \
  "$bin" status --study 1 --domain 90 --localhost-only --timeout 1
check "run-one with a bad request" expect_exit 2 "request" sh -c "echo '{\"params\": {}}' | '$bindir/cpgmatch-sim-worker' --run-one"

# A small local study runs end to end and writes its results.
printf 'name: tiny\nbudget: 6\ninitial_points: 4\nrollout: {entrain_s: 1.0, eval_s: 1.0}\n' >"$tmp/tiny.yaml"
"$bin" study run --config "$tmp/tiny.yaml" --workers 2 --out "$tmp/tiny" --quiet --json --jitter 2 >"$tmp/study.json" 2>"$tmp/study.err"
check "study science report" python3 -c "
import json; s=json.load(open('$tmp/study.json')); assert s['rollouts']==6 and s['best']['cost'] is not None, s
assert s['jitter']['draws']==2, s['jitter']"
check "study trials file" test "$(wc -l <"$tmp/tiny/trials.jsonl")" -eq 6
check "study writes analysis.json" test -s "$tmp/tiny/analysis.json"
if command -v gnuplot >/dev/null; then
  check "study figures" test -s "$tmp/tiny/fig5a.png" -a -s "$tmp/tiny/fig5b.svg" -a -s "$tmp/tiny/fig6.png" -a -s "$tmp/tiny/fig4.png"
  check "no gnuplot failure" sh -c "! grep -q 'gnuplot failed' '$tmp/study.err'"
fi

# analyze: the science report of the store just written, with the window statistics.
"$bin" analyze --store "$tmp/tiny/study.db" --json --jitter 0 >"$tmp/an.json"
check "analyze json windows" python3 -c "
import json; r=json.load(open('$tmp/an.json'))
w=r['windows'][0]
assert (w['first'], w['last'], w['rollouts']) == (1, 6, 6), w
assert {'falls','walked','feedback_mean','feedback_median','normalized_torque_median','summed_torque_median_nm','speed_mean_mps'} <= set(w), w
assert r['falls']['initial'] + r['falls']['after'] == r['falls']['total']
assert r['paper']['falls']['total'] == 16 and r['jitter'] is None"
check "analyze prints one line" test "$(wc -l <"$tmp/an.json")" -eq 1
"$bin" analyze --store "$tmp/tiny/study.db" --study 1 --jitter 0 >"$tmp/an.txt"
check "analyze table beside the paper" grep -q "J_feedback vs speed-corrected torque residual" "$tmp/an.txt"
check "analyze unknown study" expect_exit 2 "\-\-study 999" "$bin" analyze --store "$tmp/tiny/study.db" --study 999
check "analyze missing store" expect_exit 2 "\-\-store" "$bin" analyze --store "$tmp/nope.db"
check "study run bad workers" expect_exit 2 "\-\-workers" "$bin" study run --workers -3
check "reproduce bad jitter" expect_exit 2 "\-\-jitter" "$bin" reproduce --jitter -1
check "analyze bad jitter" expect_exit 2 "\-\-jitter" "$bin" analyze --store "$tmp/tiny/study.db" --jitter -1
check "plot needs one source" expect_exit 2 "\-\-store" "$bin" plot
# export: one row per stored trial; bad input names the flag.
"$bin" export --store "$tmp/tiny/study.db" --format csv >"$tmp/tiny.csv" 2>/dev/null
check "export csv: a header and one row per trial" test "$(wc -l <"$tmp/tiny.csv")" -eq 7
check "export csv columns" sh -c "head -1 '$tmp/tiny.csv' | grep -q 'cost,J_feedback,J_distance,J_pitch,J_contact,J_periodicity,feedback_late_touchdown'"
"$bin" export --store "$tmp/tiny/study.db" --study 1 --format json --out "$tmp/tiny-export.json" 2>/dev/null
check "export json" python3 -c "
import json; j=json.load(open('$tmp/tiny-export.json')); t=j['studies'][0]['trials']
assert len(t)==6 and all(set(r['params'])=={'hip_offset','hip_amplitude','duty_factor_front','duty_factor_hind','knee_phase_shift','overswing'} for r in t)"
check "export bad format" expect_exit 2 "\-\-format" "$bin" export --store "$tmp/tiny/study.db" --format xlsx
check "export missing store" expect_exit 2 "\-\-store" "$bin" export --store "$tmp/nope.db" --format csv
check "export unknown study" expect_exit 2 "\-\-study 999" "$bin" export --store "$tmp/tiny/study.db" --study 999 --format csv
check "plot unknown study" expect_exit 2 "\-\-study 999" "$bin" plot --store "$tmp/tiny/study.db" --study 999
check "plot not a trace" expect_exit 2 "\-\-trace" "$bin" plot --trace "$tmp/tiny/trials.jsonl"
check "reproduce bad seeds" expect_exit 2 "\-\-seeds" "$bin" reproduce --seeds 0
check "reproduce bad first seed" expect_exit 2 "\-\-first-seed" "$bin" reproduce --first-seed -1
check "reproduce first seed past the int range" expect_exit 2 "\-\-first-seed" "$bin" reproduce --first-seed 2147483647 --seeds 2
if command -v gnuplot >/dev/null; then
  "$bin" plot --store "$tmp/tiny/study.db" --out "$tmp/figs" >"$tmp/plot.out"
  check "plot --store figures" test -s "$tmp/figs/fig5a.png" -a -s "$tmp/figs/fig6.svg"
  "$bin" plot --trace "$tmp/t.csv" --out "$tmp/figs" >>"$tmp/plot.out"
  check "plot --trace figure" sh -c "head -c 4 '$tmp/figs/fig4.png' | grep -q PNG && grep -q '<svg' '$tmp/figs/fig4.svg'"
fi

# reproduce: two tiny replicates through the service (seeds 3 and 4), aggregated as mean ± sd.
"$bin" reproduce --seeds 2 --first-seed 3 --config "$tmp/tiny.yaml" --workers 2 --out "$tmp/rep" --jitter 0 --quiet >"$tmp/rep.txt" 2>"$tmp/rep.err"
check "reproduce replicates.json" python3 -c "
import json; r=json.load(open('$tmp/rep/replicates.json')); s=r['statistics']
assert r['replicates']==2 and s['rollouts']['n']==2 and s['rollouts']['mean']==6, s['rollouts']
assert s['falls.total']['paper']==16 and len(r['reports'])==2"
check "reproduce seeds differ" python3 -c "
import json; r=json.load(open('$tmp/rep/replicates.json'))
assert [x['name'] for x in r['reports']]==['tiny-seed-3','tiny-seed-4'], [x['name'] for x in r['reports']]"
check "reproduce writes one folder per seed" test -s "$tmp/rep/seed-3/analysis.json" -a -s "$tmp/rep/seed-4/analysis.json"
check "reproduce table" grep -q "mean ± sd" "$tmp/rep.txt"

# Issue 34: what an attacker or a careless user gives is refused in words, escaped when echoed, and a read
# never writes. (Domain 90: nothing here reaches DDS; every check fails before an optimizer is looked for.)
printf 'name: s\nbud\xe2\x80\xaeget\xff: 3\n' >"$tmp/bidi.yaml"
check "a bidi override and a bad byte are echoed escaped" expect_exit 2 'bud\\u202eget\\xff' \
  "$bin" study submit --config "$tmp/bidi.yaml" --domain 90 --localhost-only --timeout 1
check "no raw U+202E reaches the terminal" sh -c "! grep -q \"$(printf '\xe2\x80\xae')\" '$tmp/err'"
check "study extend -1 names the value" expect_exit 2 "'-1' is not a study id" "$bin" study extend -1 --budget 5 --domain 90
check "status --study 0 names the value" expect_exit 2 "'0' is not a study id" "$bin" status --study 0 --domain 90
printf 'trunk: {mass_kg: {value: 1.0e308}}\n' >"$tmp/heavy.yaml"
check "a 1e308 kg trunk is refused, not a SIGABRT" expect_exit 2 "heavy.yaml:1: field 'trunk.mass_kg': 1e+308 is outside the physical range" \
  "$bin" rollout --model "$tmp/heavy.yaml"
printf 'simulation:\n  physics_rate_hz: 1.0e9\n' >"$tmp/fast.yaml"
check "physics at 1 GHz is refused" expect_exit 2 "fast.yaml:2: field 'simulation.physics_rate_hz'" "$bin" rollout --model "$tmp/fast.yaml"
printf 'name: s\nmodel: /dev/zero\n' >"$tmp/zero.yaml"
check "model: /dev/zero is refused before reading" expect_exit 2 "zero.yaml:2: field 'model'.*not a regular file" \
  timeout 20 "$bin" study resolve --config "$tmp/zero.yaml"
mkfifo "$tmp/pipe.yaml"
printf 'name: s\nmodel: pipe.yaml\n' >"$tmp/piped.yaml"
check "a named pipe as model does not hang" expect_exit 2 "named pipe" timeout 20 "$bin" study resolve --config "$tmp/piped.yaml"
check "a named pipe as study file does not hang" expect_exit 2 "not a regular file" timeout 20 "$bin" study resolve --config "$tmp/pipe.yaml"
printf 'name: s\nbudget: 30\nconstraints: ["hip_offset / (hip_amplitude - hip_amplitude) <= 1"]\n' >"$tmp/div.yaml"
check "a division by zero in a constraint is refused" expect_exit 2 "div.yaml:3.*division by zero" "$bin" study resolve --config "$tmp/div.yaml"
: >"$tmp/empty.db"
check "export of an empty file refuses it" expect_exit 2 "not a cpgmatch study store" "$bin" export --store "$tmp/empty.db" --format csv
check "and writes nothing into it" test ! -s "$tmp/empty.db"
check "report of an empty file refuses it" expect_exit 2 "not a cpgmatch study store" "$bin" report --store "$tmp/empty.db" --out "$tmp/rep-empty"
check "store check of an empty file refuses it" expect_exit 2 "not a cpgmatch study store" "$bin" store check --store "$tmp/empty.db"
check "export of a FIFO refuses it" expect_exit 2 "not a regular file" timeout 20 "$bin" export --store "$tmp/pipe.yaml" --format csv

echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
