#!/usr/bin/env bash
# A study owns its objective (study_spec.hpp). Two workers whose local configs differ (one with cost
# weights of 4 and a 5 N m/rad knee spring) serve one lockstep study whose file overrides the knee spring
# (to 20 N m/rad, a value neither worker's files have): every stored cost equals `cpgmatch rerun` of its
# trial, to the bit, from the store alone. `study show` resubmitted gives the same spec hash. A worker of
# another objective version refuses the study's candidates with the reason; the study waits, says so and
# mixes nothing. An old store (written before specs, kept as a fixture) opens and serves its open study.
source "$(dirname "$0")/lib.sh"
FIXTURES=$(cd "$(dirname "$0")/../fixtures" && pwd)
CONFIGS=$(cd "$(dirname "$0")/../../configs" && pwd)

# The other host's configs: other cost weights and a softer knee spring.
cp -r "$CONFIGS" "$WORK/other-configs"
sed -i 's/weights: {feedback: 1.0,/weights: {feedback: 4.0,/' "$WORK/other-configs/rollout.yaml"
python3 - "$WORK/other-configs/model/morti.yaml" <<'PY'
import re, sys
p = sys.argv[1]
s = open(p).read()
s, n = re.subn(r'(knee_spring:.*?stiffness_nm_per_rad: \{value: )15\.0', r'\g<1>5.0', s, count=1, flags=re.S)
assert n == 1, "knee spring not found"
open(p, "w").write(s)
PY
grep -q "feedback: 4.0" "$WORK/other-configs/rollout.yaml" || fail "could not change the other host's weights"

cat >"$WORK/s.yaml" <<YAML
name: stiff-knee
budget: 8
initial_points: 4
seed: 11
lockstep: 2
rollout: {entrain_s: 0.5, eval_s: 0.5}
model: {knee_spring: {stiffness_nm_per_rad: 20}}
YAML
start_optimizer "$WORK/s.db"
start_worker default --slots 1
CPGMATCH_CONFIG_DIR="$WORK/other-configs" start_worker other --slots 1
id=$(cli study submit --config "$WORK/s.yaml" --timeout 30) || fail "submit failed"
wait_until 120 study_is "$id" done || fail "study not done: $(state_json "$id")"
by=$(sql "$WORK/s.db" "select group_concat(distinct json_extract(report_json,'$.worker_id')) from trials where study_id=$id")
[[ $by == *default* && $by == *other* ]] || fail "both workers should have served the study, got: $by"
for t in $(seq 0 7); do
  out=$("$BIN/cpgmatch" rerun --store "$WORK/s.db" --study "$id" --trial "$t" --json) || fail "rerun of trial $t failed"
  [[ $(json_field "$out" equal) == True ]] || fail "trial $t: stored and recomputed cost differ: $out"
done
# The stored spec is the override's, whatever the workers' files say.
[[ $(sql "$WORK/s.db" "select json_extract(spec_json,'$.model.knee_spring.stiffness_nm_per_rad.value') from studies where study_id=$id") == 20.0 ]] \
  || fail "the stored spec does not hold the study's knee spring"

# study show, resubmitted: the same spec hash.
"$BIN/cpgmatch" study show --store "$WORK/s.db" --study "$id" >"$WORK/shown.yaml" || fail "study show failed"
sha=$(sql "$WORK/s.db" "select spec_sha256 from studies where study_id=$id")
id2=$(cli study submit --config "$WORK/shown.yaml" --timeout 30) || fail "resubmitting study show's output failed"
[[ $(sql "$WORK/s.db" "select spec_sha256 from studies where study_id=$id2") == "$sha" ]] || fail "study show resubmitted gives another spec"
cli study stop "$id2" >/dev/null || true

# A worker of another objective version: refuses, with the reason; the study waits and says so, mixes nothing.
kill "$WORKER_PID"
for p in "${PIDS[@]}"; do [[ $p == "$OPT_PID" ]] || kill "$p" 2>/dev/null || true; done
sleep 3  # the optimizer drops the stopped workers
start_worker future --slots 1 --objective-version 99
sed -i 's/^name: .*/name: version-mismatch/' "$WORK/s.yaml"
id3=$(cli study submit --config "$WORK/s.yaml" --timeout 30) || fail "submit failed"
waits() { [[ $(json_field "$(state_json "$id3")" message) == *"worker future refused it"*"objective version 3; this worker computes version 99"* ]]; }
wait_until 30 waits || fail "the study does not say why it waits: $(state_json "$id3")"
[[ $(json_field "$(state_json "$id3")" completed) == 0 ]] || fail "a refused candidate was counted"
refusals=$(sql "$WORK/s.db" "select count(*) from attempts where study_id=$id3 and outcome='refused'")
[[ $refusals -ge 1 ]] || fail "no refusal on record"
# Refusals are paced (a backoff), not a loop of messages.
sleep 4
r2=$(sql "$WORK/s.db" "select count(*) from attempts where study_id=$id3 and outcome='refused'")
((r2 - refusals <= 4)) || fail "refusals not paced: $refusals then $r2 in 4 s"
start_worker current --slots 1
wait_until 60 study_is "$id3" done || fail "the study did not finish on a worker of its version: $(state_json "$id3")"
[[ $(sql "$WORK/s.db" "select count(*) from trials where study_id=$id3 and json_extract(report_json,'$.worker_id')='future'") == 0 ]] \
  || fail "the other version's worker produced results"
kill "$OPT_PID"; wait "$OPT_PID" 2>/dev/null || true

# An old store, written before specs: opens, its studies get a spec marked as migrated with the objective
# version of the releases before specs (1), so this release's workers (version 3) refuse its open study's
# candidates and it says so instead of mixing objectives; a worker of version 1 serves it.
cp "$FIXTURES/store-0.1.0-before-specs.db" "$WORK/old.db"
start_optimizer "$WORK/old.db"
wait_until 30 study_is 2 running || fail "the old store's open study is not served: $(state_json 2)"
[[ $(sql "$WORK/old.db" "select count(*) from studies where spec_origin like 'migrated:%objective version 1%' and json_extract(spec_json, '$.objective_version') = 1") == 2 ]] \
  || fail "old studies not migrated as version 1: $(sql "$WORK/old.db" 'select study_id, spec_origin from studies')"
old_waits() { [[ $(json_field "$(state_json 2)" message) == *"objective version 1; this worker computes version 3"* ]]; }
wait_until 30 old_waits || fail "the migrated study does not say why it waits: $(state_json 2)"
start_worker version1 --slots 1 --objective-version 1
wait_until 60 study_is 2 done || fail "the old store's open study did not finish on a version-1 worker: $(state_json 2)"
# Its finished (real-rollout) study re-derives from the store; the rerun names both versions.
out=$("$BIN/cpgmatch" rerun --store "$WORK/old.db" --study 1 --trial 5 --json 2>"$WORK/rerun.err") || fail "rerun on the old store failed"
[[ $(json_field "$out" spec_objective_version) == 1 && $(json_field "$out" rerun_objective_version) == 3 ]] || fail "rerun versions: $out"
grep -q "objective version 1; this release computes version 3" "$WORK/rerun.err" || fail "rerun did not say the versions differ"
echo "old store trial 5 under version 3: equal=$(json_field "$out" equal)"
echo "PASS study specs: 8/8 trials of a study served by differently configured workers re-run to the bit;" \
  "study show resubmitted: same hash $sha; version-99 worker refused $r2 times, 0 mixed; old store migrated as version 1 and served by a version-1 worker"
