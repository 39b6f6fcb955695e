#!/usr/bin/env bash
# `cpgmatch calibrate` through the executable: bad flags and bad traces exit 2 naming the flag or the
# file:line; a trace of the worn-knee-spring robot gives a calibrated model that loads and holds the fit.
set -u
bin="$1"
configs="$2"
source "$(dirname "$0")/cli_lib.sh"

params="$configs/params/matched-trot.yaml"
"$bin" rollout --model "$configs/model/worn-knee-spring.yaml" --params "$params" --entrain 1 --eval 1 --seed 3 \
  --trace "$tmp/worn.csv" >/dev/null || { echo "FAIL: rollout for the trace"; exit 1; }
knee=knee_spring.stiffness_nm_per_rad
run() { "$bin" calibrate --out "$tmp/cal.yaml" "$@"; }

check "no trace" expect_exit 2 "\-\-trace" run --params-file "$params" --params $knee
check "no params file" expect_exit 2 "\-\-params-file: required with \-\-trace" run --trace "$tmp/worn.csv" --params $knee
check "trace and store" expect_exit 2 "either \-\-trace" run --trace "$tmp/worn.csv" --store "$tmp/s.db" --study 1
check "store without study" expect_exit 2 "\-\-study: required with \-\-store" run --store "$tmp/s.db"
check "no such store" expect_exit 2 "nope.db: no such file" run --store "$tmp/nope.db" --study 1
check "store with params file" expect_exit 2 "\-\-params-file: not with \-\-store" \
  run --store "$tmp/nope.db" --study 1 --params-file "$params"
check "unknown value" expect_exit 2 "\-\-params: 'knee_spring.stifness' is not a model value" \
  run --trace "$tmp/worn.csv" --params-file "$params" --params knee_spring.stifness
check "a robot's value on a model file" expect_exit 2 "knee_parallel_spring.stiffness_nm_per_rad is a value of a robot's description" \
  run --trace "$tmp/worn.csv" --params-file "$params" --params knee_parallel_spring.stiffness_nm_per_rad
check "value twice" expect_exit 2 "named twice" run --trace "$tmp/worn.csv" --params-file "$params" --params $knee,$knee
check "window 0" expect_exit 2 "\-\-window" run --trace "$tmp/worn.csv" --params-file "$params" --params $knee --window 0
check "window nan" expect_exit 2 "\-\-window" run --trace "$tmp/worn.csv" --params-file "$params" --params $knee --window nan
check "windows 0" expect_exit 2 "\-\-windows" run --trace "$tmp/worn.csv" --params-file "$params" --params $knee --windows 0
check "grid negative" expect_exit 2 "\-\-grid" run --trace "$tmp/worn.csv" --params-file "$params" --params $knee --grid -1
check "step too large" expect_exit 2 "\-\-relative-step" run --trace "$tmp/worn.csv" --params-file "$params" --params $knee --relative-step 1
check "missing trace file" expect_exit 2 "nope.csv: cannot open" run --trace "$tmp/nope.csv" --params-file "$params" --params $knee
cut -d, -f1-4 "$tmp/worn.csv" >"$tmp/short.csv"
check "trace without columns" expect_exit 2 "short.csv:1: no column 'vx_mps'" \
  run --trace "$tmp/short.csv" --params-file "$params" --params $knee
awk -F, 'BEGIN { OFS = "," } NR == 5 { $4 = "x" } { print }' "$tmp/worn.csv" >"$tmp/badcell.csv"
check "bad cell names file:line and column" expect_exit 2 "badcell.csv:5: column 'pitch_rad': 'x' is not a finite number" \
  run --trace "$tmp/badcell.csv" --params-file "$params" --params $knee
check "trace of other parameters" expect_exit 2 "made with other ones" \
  run --trace "$tmp/worn.csv" --params-file "$configs/params/default.yaml" --params $knee
printf 'knee_spring: {stiffness_nm_per_rad: {value: 100.0}}\n' >"$tmp/stiff.yaml"
check "start outside the physical range" expect_exit 2 "outside its physical range" \
  run --trace "$tmp/worn.csv" --params-file "$params" --params $knee --model "$tmp/stiff.yaml"

# The fit: the trace's robot has 12 N m/rad knees, the start model 15.
out=$(run --trace "$tmp/worn.csv" --params-file "$params" --params $knee --window 2 --json 2>"$tmp/err")
check "calibrate runs" test $? -eq 0
check "estimate within 10% of 12" python3 -c "
import json, sys
r = json.loads(sys.argv[1]); v = r['values'][0]
assert v['name'] == '$knee' and abs(v['estimate'] / 12.0 - 1) < 0.1, v
assert v['standard_deviation'] > 0 and r['cost_after'] < r['cost_before'], r
# The default: three windows of the 2-s trace (--window 2 x 3 windows is longer than the trace), each fitted
# alone; the sd is the larger of the covariance's and the windows' scatter, and says which.
assert r['windows'] == 3 and len(v['window_estimates']) == 3, r
assert v['standard_deviation'] == max(v['covariance_sd'], v['window_sd']) and v['identifiable'], v
assert v['sd_from'] in ('covariance', 'windows'), v" "$out"
check "calibrated model says so" grep -q "stiffness_nm_per_rad: {value: 1[12]\.[0-9]*, source: \"calibrated: estimate" "$tmp/cal.yaml"
check "calibrated model's header names the windows" grep -q "the spread of 3 windows fitted alone" "$tmp/cal.yaml"
check "calibrated model loads" "$bin" rollout --model "$tmp/cal.yaml" --entrain 0 --eval 0.1 --json >/dev/null

echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
