#!/usr/bin/env python3
"""How well `cpgmatch calibrate` recovers the values of the reality-gap models (configs/model/*.yaml).

Usage: tests/bench/calibration_recovery.py BUILD_DIR [--window S=3] [--noise RAD=0] [--only CASE] [--save F.json]
                                            [extra `cpgmatch calibrate` flags, e.g. --grid 8]
For each case: rollouts of the scenario's robot (two gaits, matched-trot.yaml and default.yaml, seeds 1 and
2: four traces of WINDOW seconds, 1 s of start-up ramp included) written as trace CSVs; then `cpgmatch
calibrate` from configs/model/morti.yaml fits the case's values, and the table gives each value's truth,
estimate, error, standard deviation, the cost before and after and the wall time. --noise adds Gaussian
noise of that standard deviation (rad) to the measured joint angles and pitch of every trace, and four times
it (m/s) to the speed, as a robot's sensors would. Cases marked "misfit" fit values that are
not the ones that differ, or leave a difference unfitted: they show what calibration does with a model
that cannot explain the robot (docs/calibration.md). Run by hand; about 1-2 minutes on one core.
"""
import csv
import json
import os
import random
import subprocess
import sys
import tempfile
import time

import yaml

build = sys.argv[1]
args = sys.argv[2:]


def option(name, default):
    if name in args:
        i = args.index(name)
        value = args[i + 1]
        del args[i:i + 2]
        return value
    return default


window = float(option("--window", "3"))
noise = float(option("--noise", "0"))
only = option("--only", None)
save = option("--save", None)
root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
models = os.path.join(root, "configs", "model")
cpgmatch = os.path.join(build, "bin", "cpgmatch")

KNEE = "knee_spring.stiffness_nm_per_rad"
MASS = "trunk.mass_kg"
CASES = [
    ("worn-knee-spring", "worn-knee-spring", [KNEE]),
    ("worn-knee-spring, 2 values", "worn-knee-spring", [KNEE, MASS]),
    ("battery-trunk", "battery-trunk", [MASS]),
    ("battery-trunk, 2 values", "battery-trunk", [KNEE, MASS]),
    ("stiff-gearbox", "stiff-gearbox", ["hip_motor.coulomb_friction_nm", "hip_motor.viscous_friction_nm_s_per_rad",
                                        "hip_motor.reflected_inertia_kg_m2", "hip_motor.no_load_speed_rad_s"]),
    ("stiff-gearbox, friction and speed", "stiff-gearbox", ["hip_motor.coulomb_friction_nm", "hip_motor.no_load_speed_rad_s"]),
    ("slippery-belt", "slippery-belt", ["contact.friction"]),
    ("late-foottiles", "late-foottiles", ["foot_sensor.sensitivity", "foot_sensor.time_constant_s",
                                          "contact.stiffness_n_per_m", "contact.damping_n_s_per_m"]),
    ("late-foottiles, sensor only", "late-foottiles", ["foot_sensor.sensitivity", "foot_sensor.time_constant_s"]),
    ("misfit: worn knee, mass fitted", "worn-knee-spring", [MASS]),
    ("misfit: worn knee + stiff gearbox, knee fitted", "worn-knee-and-stiff-gearbox", [KNEE]),
]


def value_of(model_file, name):
    section, key = name.split(".")
    entry = yaml.safe_load(open(model_file))[section][key]
    return float(entry["value"] if isinstance(entry, dict) else entry)


def combined_model(tmp):
    """worn-knee-spring.yaml with stiff-gearbox.yaml's hip motor: two gaps at once."""
    worn = yaml.safe_load(open(os.path.join(models, "worn-knee-spring.yaml")))
    worn["hip_motor"] = yaml.safe_load(open(os.path.join(models, "stiff-gearbox.yaml")))["hip_motor"]
    path = os.path.join(tmp, "worn-knee-and-stiff-gearbox.yaml")
    yaml.safe_dump(worn, open(path, "w"))
    return path


def add_noise(path, rng):
    rows = list(csv.reader(open(path)))
    header = rows[0]
    noisy = [i for i, h in enumerate(header) if h.endswith("_hip_rad") or h.endswith("_knee_rad") or h == "pitch_rad"]
    speed = header.index("vx_mps")
    for row in rows[1:]:
        for i in noisy:
            row[i] = f"{float(row[i]) + rng.gauss(0, noise):.4f}"
        row[speed] = f"{float(row[speed]) + rng.gauss(0, 4 * noise):.5f}"
    csv.writer(open(path, "w", newline="")).writerows(rows)


def traces(model_file, tmp, tag):
    out = []
    rng = random.Random(7)
    for params in ("matched-trot", "default"):
        for seed in (1, 2):
            path = os.path.join(tmp, f"{tag}-{params}-{seed}.csv")
            subprocess.run([cpgmatch, "rollout", "--model", model_file, "--params",
                            os.path.join(root, "configs", "params", params + ".yaml"), "--entrain", "1", "--eval",
                            str(window - 1), "--seed", str(seed), "--trace", path], check=True, stdout=subprocess.DEVNULL)
            if noise > 0:
                add_noise(path, rng)
            out.append((params, path))
    return out


def calibrate(trace_list, params, values, tmp):
    cmd = [cpgmatch, "calibrate", "--params-file", os.path.join(root, "configs", "params", params + ".yaml"),
           "--params", ",".join(values), "--out", os.path.join(tmp, "calibrated.yaml"), "--window", str(window), "--windows", "1", "--json"]
    for path in trace_list:
        cmd += ["--trace", path]
    cmd += args  # the flags left after this script's own
    start = time.time()
    done = subprocess.run(cmd, check=True, capture_output=True, text=True)
    result = json.loads(done.stdout)
    result["wall_s_total"] = time.time() - start
    return result


if any(not a.startswith("-") and not a.replace(".", "").isdigit() for a in args):
    sys.exit(f"unexpected arguments: {args}")
results = []
with tempfile.TemporaryDirectory() as tmp:
    for name, scenario, values in CASES:
        if only and only not in name:
            continue
        model_file = combined_model(tmp) if scenario == "worn-knee-and-stiff-gearbox" else os.path.join(models, scenario + ".yaml")
        made = traces(model_file, tmp, scenario)
        # One calibration per gait: its traces share the CPG parameters `calibrate` re-runs.
        for params in ("matched-trot", "default"):
            r = calibrate([p for g, p in made if g == params], params, values, tmp)
            print(f"\n{name} ({params}, 2 traces x {window:g} s, noise {noise:g}): cost {r['cost_before']:.4g} -> "
                  f"{r['cost_after']:.4g}, {r['iterations']} iterations, {r['replays']} replays, {r['wall_time_s']:.1f} s")
            for v in r["values"]:
                truth = value_of(model_file, v["name"])
                error = 100.0 * (v["estimate"] / truth - 1.0) if truth != 0 else float("nan")
                sd = v["standard_deviation"]
                print(f"  {v['name']:<42} truth {truth:<10.4g} start {v['initial']:<10.4g} estimate {v['estimate']:<10.4g}"
                      f" error {error:+7.2f}%  sd {sd if sd is not None else float('nan'):.3g}"
                      f"{'  AT BOUND' if v['at_bound'] else ''}")
                results.append({"case": name, "gait": params, "value": v["name"], "truth": truth, "estimate": v["estimate"],
                                "error_pct": error, "sd": sd, "cost_before": r["cost_before"], "cost_after": r["cost_after"],
                                "wall_s": r["wall_time_s"], "noise": noise, "window_s": window})
if save:
    json.dump(results, open(save, "w"), indent=1)
