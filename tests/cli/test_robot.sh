#!/usr/bin/env bash
# `cpgmatch robot list|check|init` and `rollout --robot` through the real executable (issue 31): every shipped
# robot is listed and checks clean (it stands for 3 s), `init` on each shipped URDF writes a skeleton that
# names every joint and guesses the shipped robot's own legs, a FILL_IN left in is refused with its line, and
# bad descriptions exit 2 naming the element and file:line.
set -u
bin="$1"
source "$(dirname "$0")/cli_lib.sh"

"$bin" robot list --json >"$tmp/list.json"
check "robot list names morti" python3 -c "import json,sys; names=[r['name'] for r in json.load(open('$tmp/list.json'))]; sys.exit(0 if 'morti' in names else 1)"
robots=$(python3 -c "import json; print(' '.join(r['name'] for r in json.load(open('$tmp/list.json'))))")
for robot in $robots; do
  "$bin" robot check "$robot" --json >"$tmp/check-$robot.json" 2>"$tmp/check-$robot.err"
  check "robot check $robot exits 0" test $? -eq 0
  check "robot check $robot: stands 3 s and runs its presets" python3 - "$tmp/check-$robot.json" <<'PY'
import json, sys
c = json.load(open(sys.argv[1]))
ok = c["total_mass_kg"] > 0 and c["standing_height_m"] > 0 and c.get("stand", {}).get("stood") is True
ok = ok and len(c.get("presets", [])) >= 1 and all(p["outcome"] in ("completed", "fell") for p in c["presets"])
sys.exit(0 if ok else 1)
PY
  dir="$(python3 -c "import json; print(json.load(open('$tmp/check-$robot.json'))['urdf'])")"
  "$bin" robot init --urdf "$dir" --out "$tmp/init-$robot" >"$tmp/init-$robot.out" 2>&1
  check "robot init on $robot's URDF exits 0" test $? -eq 0
  check "robot init on $robot names every joint of the URDF" python3 - "$dir" "$tmp/init-$robot/robot.yaml" <<'PY'
import sys, xml.etree.ElementTree as ET
joints = [j.get("name") for j in ET.parse(sys.argv[1]).getroot().findall("joint")]
text = open(sys.argv[2]).read()
sys.exit(0 if joints and all(j in text for j in joints) else 1)
PY
  check "robot init on $robot guesses its legs (same hips as robot.yaml)" python3 - "$tmp/check-$robot.json" "$tmp/init-$robot/robot.yaml" <<'PY'
import json, sys, re
hips = sorted(l["hip"] for l in json.load(open(sys.argv[1]))["legs"])
guessed = sorted(re.findall(r"^  - \{name: .*hip: ([^,}\s]+)", open(sys.argv[2]).read(), re.M))
sys.exit(0 if hips == guessed else 1)
PY
  check "a skeleton's FILL_IN is refused with its line" expect_exit 2 "robot.yaml:[0-9]*: field '.*' is still FILL_IN" "$bin" robot check "$tmp/init-$robot"
done
check "init refuses to overwrite" expect_exit 2 "already holds a robot.yaml" "$bin" robot init --urdf "$dir" --out "$tmp/init-$robot"

# Bad descriptions: a copy of Morti, broken one way at a time.
cp -r "$(dirname "$(python3 -c "import json; print(json.load(open('$tmp/check-morti.json'))['yaml'])")")" "$tmp/m"
sed 's/knee: HL_knee/knee: HL_knee_joint/' "$tmp/m/robot.yaml" >"$tmp/m/y" && mv "$tmp/m/y" "$tmp/m/robot.yaml"
check "a joint the URDF lacks names robot.yaml:line" expect_exit 2 "robot.yaml:[0-9]*: field 'legs\[2\].knee': joint 'HL_knee_joint' is not in" "$bin" robot check "$tmp/m"
check "rollout --robot refuses it the same way" expect_exit 2 "joint 'HL_knee_joint' is not in" "$bin" rollout --robot "$tmp/m"
cp -r "$tmp/m" "$tmp/m2"; sed -i 's/knee: HL_knee_joint/knee: HL_knee/; s/<mass value="0.04"\/>/<mass value="0"\/>/' "$tmp/m2/robot.yaml" "$tmp/m2/robot.urdf"
check "a zero mass names robot.urdf:line" expect_exit 2 "robot.urdf:[0-9]*: link 'FL_foot': mass must be > 0" "$bin" robot check "$tmp/m2"
check "an unknown robot lists the shipped ones" expect_exit 2 "shipped: .*morti" "$bin" robot check no-such-robot
check "a special file is refused" expect_exit 2 "not a regular file" "$bin" robot init --urdf /dev/zero --out "$tmp/z"
check "--robot and --model together" expect_exit 2 "excludes" "$bin" rollout --robot morti --model x.yaml

# rollout --robot morti is the default model's rollout: the same to 1e-9 of the cost (the URDF's knee stops are
# relative to the standing angle, so 1.0 + (-0.8) differs from 0.2 in the last bit; nothing else differs).
"$bin" rollout --robot morti --entrain 2 --eval 2 --json >"$tmp/a.json"
"$bin" rollout --entrain 2 --eval 2 --json >"$tmp/b.json"
check "rollout --robot morti equals the default model's rollout" python3 -c "import json; a=json.load(open('$tmp/a.json')); b=json.load(open('$tmp/b.json')); exit(0 if abs(a['cost']-b['cost'])<=1e-9*abs(b['cost']) and a['fell']==b['fell'] else 1)"

# eval-rollout and optimize --objective rollout take a robot: eval-rollout --robot NAME --preset P is the rollout
# `robot check` runs for that preset (same cost to 1e-9); optimize --robot searches the robot's search_space with
# the preset's other values fixed, and passes the robot on to every evaluation.
"$bin" robot check moteus-hexapod --json >"$tmp/hex.json"
echo '{}' | "$bin" eval-rollout --robot moteus-hexapod --preset tripod >"$tmp/hex-eval.out"
check "eval-rollout --robot --preset costs what robot check's preset costs" python3 - "$tmp/hex.json" "$tmp/hex-eval.out" <<'PY'
import json, sys
c = {p["name"]: p["cost"] for p in json.load(open(sys.argv[1]))["presets"]}
cost = float(open(sys.argv[2]).read().split()[-1])
sys.exit(0 if abs(cost - c["tripod"]) <= 1e-9 * abs(c["tripod"]) else 1)
PY
echo '{}' | "$bin" eval-rollout --robot moteus-hexapod --preset slow --gait wave >"$tmp/wave.out"
echo '{}' | "$bin" eval-rollout --robot moteus-hexapod --preset slow --gait tripod >"$tmp/tripod.out"
check "eval-rollout --gait changes the gait" python3 -c "import sys; a=float(open('$tmp/wave.out').read().split()[-1]); b=float(open('$tmp/tripod.out').read().split()[-1]); sys.exit(0 if a != b else 1)"
echo '{}' >"$tmp/empty-point.json"
check "eval-rollout --gait unknown to the robot" expect_exit 2 "robot 'moteus-hexapod' has gaits tripod, ripple, wave" bash -c "\"$bin\" eval-rollout --robot moteus-hexapod --gait trot <\"$tmp/empty-point.json\""
check "optimize --robot with an unknown preset" expect_exit 2 "preset 'nope': robot 'odrive-quadruped' has presets" "$bin" optimize --objective rollout --robot odrive-quadruped --preset nope --budget 2
check "optimize --preset without --robot" expect_exit 2 "need --robot" "$bin" optimize --objective rollout --preset trot --budget 2
"$bin" optimize --objective rollout --robot odrive-quadruped --budget 4 --initial 3 --seed 5 --json --quiet >"$tmp/opt.json"
check "optimize --robot searches the robot's space, the preset's frequency and knee amplitude fixed" python3 - "$tmp/opt.json" <<'PY'
import json, sys
o = json.load(open(sys.argv[1]))
searched = {"hip_offset", "hip_amplitude", "duty_factor_front", "duty_factor_hind", "knee_phase_shift", "overswing"}
ok = o["evaluations"] == 4 and o["failed"] == 0 and o["best"] is not None
for t in o["trials"]:
    p = t["params"]
    ok = ok and set(p) == searched | {"frequency", "knee_amplitude"} and p["frequency"] == 1.5 and p["knee_amplitude"] == 0.4
    ok = ok and 0.1 <= p["hip_amplitude"] <= 0.5   # the robot's range, not the paper's 0.65
sys.exit(0 if ok else 1)
PY

# The shipped study files (configs/studies/): each resolves to a spec of its robot, whose hash differs per robot.
# A study of a robot's variant (moteus-hexapod-free: the hexapod's free-standing overlay) names the base robot,
# so the file's name starts with the robot's.
configs="$(cd "$(dirname "$0")/../../configs" && pwd)"
for study in "$configs"/studies/*.yaml; do
  name=$(basename "$study" .yaml)
  "$bin" study resolve --config "$study" --json >"$tmp/spec-$name.json" 2>"$tmp/spec-$name.err"
  check "configs/studies/$name.yaml resolves" test $? -eq 0
  check "configs/studies/$name.yaml is a study of robot $name" python3 - "$tmp/spec-$name.json" "$name" <<'PY'
import json, sys
robot = json.load(open(sys.argv[1]))["spec"]["robot"]["name"]
sys.exit(0 if sys.argv[2] == robot or sys.argv[2].startswith(robot + "-") else 1)
PY
done

echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
