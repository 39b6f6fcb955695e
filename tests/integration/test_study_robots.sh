#!/usr/bin/env bash
# A study per shipped robot, and one of a robot the service has never seen, through the optimizer service on
# loopback (issue 31, "the study owns its robot"). The simulation worker's configs have no robots folder at
# all: it builds each robot from the spec alone. Every stored cost equals `cpgmatch rerun` of its trial, to
# the bit, from the store alone. A robot with a bad URDF is refused at submit (exit 2, naming the URDF's
# line) and the service keeps serving.
source "$(dirname "$0")/lib.sh"
CONFIGS=$(cd "$(dirname "$0")/../../configs" && pwd)

cp -r "$CONFIGS" "$WORK/worker-configs"
rm -rf "$WORK/worker-configs/robots"  # the worker has no copy of any robot
start_optimizer "$WORK/s.db"
CPGMATCH_CONFIG_DIR="$WORK/worker-configs" start_worker w1 --slots 2

# A robot of the lab's own: a copy of the hexapod under another name, beside the study file.
mkdir -p "$WORK/robots"
cp -r "$CONFIGS/robots/moteus-hexapod" "$WORK/robots/our-hexapod"
sed -i 's/^name: moteus-hexapod/name: our-hexapod/' "$WORK/robots/our-hexapod/robot.yaml"
grep -q "^name: our-hexapod" "$WORK/robots/our-hexapod/robot.yaml" || fail "could not rename the copied robot"

for robot in odrive-quadruped moteus-hexapod robots/our-hexapod; do
  tag=${robot##*/}
  cat >"$WORK/$tag.yaml" <<YAML
name: study-of-$tag
budget: 6
initial_points: 4
seed: 3
lockstep: 2
rollout: {entrain_s: 1.0, eval_s: 1.0}
robot: $robot
YAML
  id=$(cli study submit --config "$WORK/$tag.yaml" --timeout 30) || fail "submit of the $tag study failed"
  wait_until 120 study_is "$id" done || fail "the $tag study is not done: $(state_json "$id")"
  name=$(sql "$WORK/s.db" "select json_extract(spec_json,'$.robot.name') from studies where study_id=$id")
  [[ $name == "$tag" ]] || fail "the $tag study's spec holds robot '$name'"
  [[ $(sql "$WORK/s.db" "select json_type(spec_json,'$.model') is null from studies where study_id=$id") == 1 ]] \
    || fail "the $tag study's spec has a model section beside its robot"
  n=$(sql "$WORK/s.db" "select count(*) from trials where study_id=$id and json_extract(report_json,'$.ok')")
  [[ $n -ge 6 ]] || fail "the $tag study has $n ok rollouts, expected 6"
  for trial in 0 5; do
    out=$("$BIN/cpgmatch" rerun --store "$WORK/s.db" --study "$id" --trial "$trial" 2>&1) || fail "rerun of $tag trial $trial: $out"
    grep -q "equal to the bit" <<<"$out" || fail "rerun of $tag trial $trial is not the stored cost: $out"
  done
  echo "study of $tag: spec of robot $name, $n rollouts, reruns equal to the bit"
done
# The two hexapods are the same body under two names: two specs, two hashes.
h1=$(sql "$WORK/s.db" "select spec_sha256 from studies where name='study-of-moteus-hexapod'")
h2=$(sql "$WORK/s.db" "select spec_sha256 from studies where name='study-of-our-hexapod'")
[[ -n $h1 && $h1 != "$h2" ]] || fail "the renamed robot's study has the same spec hash ($h1, $h2)"

# A bad robot: a link of negative mass. The client refuses it before sending, naming the URDF's line.
cp -r "$WORK/robots/our-hexapod" "$WORK/robots/broken"
sed -i '0,/<mass value="6.6"\/>/s//<mass value="-1"\/>/' "$WORK/robots/broken/robot.urdf"
sed -e 's/^name: .*/name: broken/' -e 's|^robot: .*|robot: robots/broken|' "$WORK/our-hexapod.yaml" >"$WORK/broken.yaml"
set +e
err=$(cli study submit --config "$WORK/broken.yaml" --timeout 30 2>&1)
rc=$?
set -e
[[ $rc == 2 ]] || fail "a robot with a negative mass: exit $rc, expected 2 ($err)"
grep -q "broken.yaml:7: field 'robot'" "$WORK/cli.log" || fail "the refusal does not name the study's line: $(tail -3 "$WORK/cli.log")"
grep -Eq "robot.urdf:[0-9]+" "$WORK/cli.log" || fail "the refusal does not name the URDF's line: $(tail -3 "$WORK/cli.log")"
study_is "$id" done || fail "the service stopped answering after the refused submit"
echo "PASS study robots: odrive-quadruped, moteus-hexapod and an unshipped copy ran on a worker with no robots; a broken URDF refused with its line"
