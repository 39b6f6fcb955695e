#!/usr/bin/env bash
# Rollouts run in parallel (as the worker's slot processes run them) give bit-identical results to the
# same rollouts run one by one.
source "$(dirname "$0")/lib.sh"
# A rollout process reads no local config: its request carries the study's whole spec.
printf 'name: parallel\n' >"$WORK/s.yaml"
spec=$("$BIN/cpgmatch" study resolve --config "$WORK/s.yaml" --json | python3 -c 'import json,sys; print(json.dumps(json.dumps(json.load(sys.stdin)["spec"])))')
requests=()
for i in 0 1 2 3; do
  requests+=("{\"params\": {\"hip_offset\": 0.0$i, \"duty_factor_front\": 0.5$i}, \"entrain_s\": 1, \"eval_s\": 1, \"terrain\": \"rough:0.002\", \"seed\": $i, \"spec\": $spec}")
done
strip() { python3 -c 'import json,sys; r=json.loads(sys.stdin.readline()); r.pop("wall_time_s"); print(json.dumps(r, sort_keys=True))'; }
for i in 0 1 2 3; do echo "${requests[$i]}" | "$BIN/cpgmatch-sim-worker" --run-one | strip >"$WORK/serial-$i"; done
for i in 0 1 2 3; do (echo "${requests[$i]}" | "$BIN/cpgmatch-sim-worker" --run-one | strip >"$WORK/parallel-$i") & done
wait
for i in 0 1 2 3; do
  cmp -s "$WORK/serial-$i" "$WORK/parallel-$i" || fail "rollout $i differs: $(cat "$WORK/serial-$i") vs $(cat "$WORK/parallel-$i")"
done
[[ $(sort -u "$WORK"/serial-* | wc -l) == 4 ]] || fail "the four rollouts should differ from each other"
echo "PASS parallel == serial for 4 rollouts"
