#!/usr/bin/env bash
# Steering a study as Optuna users can (issue 24), with real processes: the optimizer, a sim worker with fake
# rollouts and the CLI. A study file with `constraints` and `enqueue: [gaits/good.yaml]` runs that gait as its
# trial 0; `study stop` halts it mid-run; the optimizer is killed and restarted; `study enqueue` queues another
# known gait in the stopped study and refuses one that breaks a constraint (exit 2, the constraint named);
# `study extend 1 --budget 5` continues it to 20 + 5 trials, the queued gait first. Every trial satisfies
# the constraints.
source "$(dirname "$0")/lib.sh"
CONFIGS="$(cd "$(dirname "$0")/../../configs" && pwd)"

mkdir -p "$WORK/gaits"
sed 's/^hip_amplitude: .*/hip_amplitude: 0.3/' "$CONFIGS/params/default.yaml" >"$WORK/gaits/good.yaml"
sed 's/^duty_factor_front: .*/duty_factor_front: 0.62/' "$CONFIGS/params/default.yaml" >"$WORK/gaits/other.yaml"
# 0.3 + 0.6 * (1 + 0.1) = 0.96 rad: outside the study's tightened envelope of 0.9 rad.
sed -e 's/^hip_offset: .*/hip_offset: 0.3/' -e 's/^hip_amplitude: .*/hip_amplitude: 0.6/' \
  "$CONFIGS/params/default.yaml" >"$WORK/gaits/wide.yaml"
write_study "$WORK/s.yaml" steer 20 4
cat >>"$WORK/s.yaml" <<'YAML'
constraints:
  - "hip_offset + hip_amplitude * (1 + overswing) <= 0.9"
  - "hip_offset - hip_amplitude * (1 + overswing) >= -0.9"
enqueue: [gaits/good.yaml]
YAML

# A constraint that does not parse is refused by the CLI before anything is sent: line and position.
sed 's/hip_amplitude \* (1/hip_amplitud * (1/' "$WORK/s.yaml" >"$WORK/bad.yaml"
set +e
"$BIN/cpgmatch" study submit --config "$WORK/bad.yaml" --domain "$DOMAIN" --localhost-only --timeout 2 2>"$WORK/bad.err"
code=$?
set -e
[[ $code == 2 ]] || fail "a bad constraint exited $code, not 2"
grep -q "bad.yaml:7: field 'constraints\[0\]': unknown parameter 'hip_amplitud'.* at position 14" "$WORK/bad.err" ||
  fail "the bad constraint's error: $(cat "$WORK/bad.err")"

start_optimizer "$WORK/s.db"
start_worker w --slots 1 --fake-rollout-ms 400
id=$(cli study submit --config "$WORK/s.yaml" --timeout 20) || fail "submit failed"
[[ $id == 1 ]] || fail "study id $id"
# The store, not `status` (a DDS client takes a second to discover): stopped early, not after its 8 s run.
done_in_store() { [[ $(sql "$WORK/s.db" "SELECT COUNT(*) FROM trials WHERE study_id = 1 AND status = 'done'") -ge $1 ]]; }
wait_until 20 done_in_store 4 || fail "the study did not start: $(state_json 1)"
cli study stop 1 >/dev/null || fail "stop failed"
wait_until 10 study_is 1 stopped || fail "not stopped: $(state_json 1)"
sleep 1  # the rollout in flight when it stopped still reports
stopped_at=$(json_field "$(state_json 1)" completed)
((stopped_at >= 4 && stopped_at < 20)) || fail "stopped at $stopped_at"
[[ $(sql "$WORK/s.db" "SELECT phase FROM trials WHERE study_id = 1 AND trial_id = 0") == enqueued ]] ||
  fail "trial 0 is not the enqueued gait"
[[ $(sql "$WORK/s.db" "SELECT json_extract(x_json, '\$[1]') FROM trials WHERE study_id = 1 AND trial_id = 0") == 0.3 ]] ||
  fail "trial 0 does not run good.yaml's hip_amplitude 0.3"

# The optimizer dies and comes back: the stopped study is extended from the store alone.
kill -9 "$OPT_PID"; wait "$OPT_PID" 2>/dev/null || true
start_optimizer "$WORK/s.db"
set +e
cli study extend 9 --budget 3 --timeout 20 >/dev/null; unknown=$?
cli study extend 1 --budget 0 --timeout 20 >/dev/null; zero=$?
set -e
[[ $unknown == 2 && $zero == 2 ]] || fail "extend of an unknown study exited $unknown, --budget 0 exited $zero (not 2)"
grep -q "no study 9" "$WORK/cli.log" || fail "the unknown study's refusal is not said"

set +e
cli study enqueue 1 --params "$WORK/gaits/wide.yaml" --timeout 20 >/dev/null; code=$?
set -e
[[ $code == 2 ]] || fail "a gait outside a constraint exited $code"
grep -q "wide.yaml: violates the study's constraint \"hip_offset + hip_amplitude \* (1 + overswing) <= 0.9\"" \
  "$WORK/cli.log" || fail "the refused gait's constraint is not named: $(tail -3 "$WORK/cli.log")"
queued=$(cli study enqueue 1 --params "$WORK/gaits/other.yaml" --timeout 20) || fail "enqueue failed"
trial=$(sed -n 's/.*queued as trial \([0-9]*\) .*/\1/p' <<<"$queued")
[[ -n $trial && $queued == *"they run once it is extended"* ]] || fail "enqueue said: $queued"
out=$(cli study extend 1 --budget 5 --timeout 20) || fail "extend failed"
[[ $out == *"budget 20 -> 25"* ]] || fail "extend said: $out"
wait_until 40 study_is 1 done || fail "the extended study did not finish: $(state_json 1)"
final=$(state_json 1)
[[ $(json_field "$final" completed) == 25 && $(json_field "$final" budget) == 25 ]] || fail "final state: $final"
# The gait queued is the trial after every one issued before it, and it ran other.yaml's values.
[[ $(sql "$WORK/s.db" "SELECT COUNT(*) FROM trials WHERE study_id = 1 AND trial_id < $trial AND issued_at > (SELECT issued_at FROM trials WHERE study_id = 1 AND trial_id = $trial)") == 0 ]] ||
  fail "a trial before $trial was issued after it"
[[ $(sql "$WORK/s.db" "SELECT phase || ' ' || json_extract(x_json, '\$[2]') FROM trials WHERE study_id = 1 AND trial_id = $trial") == "enqueued 0.62" ]] ||
  fail "trial $trial is not other.yaml's gait"
[[ $(sql "$WORK/s.db" "SELECT COUNT(*) FROM trials WHERE study_id = 1 AND status = 'done'") == 25 ]] ||
  fail "not 25 trials done"
# Every trial, design and proposals alike, inside both constraints.
violations=$(sql "$WORK/s.db" "SELECT COUNT(*) FROM trials WHERE study_id = 1 AND (
  json_extract(x_json, '\$[0]') + json_extract(x_json, '\$[1]') * (1 + json_extract(x_json, '\$[5]')) > 0.9 OR
  json_extract(x_json, '\$[0]') - json_extract(x_json, '\$[1]') * (1 + json_extract(x_json, '\$[5]')) < -0.9)")
[[ $violations == 0 ]] || fail "$violations trials violate a constraint"
# The export says where each trial came from.
"$BIN/cpgmatch" export --store "$WORK/s.db" --study 1 --format csv --out "$WORK/trials.csv" 2>>"$WORK/cli.log" ||
  fail "export failed"
[[ $(grep -c ',enqueued,' "$WORK/trials.csv") -ge 2 ]] || fail "the export does not mark the enqueued trials: $(head -3 "$WORK/trials.csv")"
echo "PASS steering: stopped at $stopped_at/20, extended to 25, gait queued as trial $trial, 0 constraint violations"
