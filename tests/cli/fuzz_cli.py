#!/usr/bin/env python3
"""Fuzz the command line: a few hundred generated argument lists (fixed seed) for `cpgmatch rollout`,
`analyze`, `optimize` and `study run`, and generated rollout settings files. Each must end with exit 0
(valid input) or 2 (bad input, with a message on stderr), never a crash, a signal, exit 1 or a hang (each
run is time-bounded).
Usage: fuzz_cli.py BIN_DIR [N=300]"""
import os
import random
import subprocess
import sys
import tempfile

bin_dir = os.path.abspath(sys.argv[1])
n = int(sys.argv[2]) if len(sys.argv) > 2 else 300
rng = random.Random(20261201)
garbage = ["nan", "inf", "-inf", "-1", "0", "1e12", "-1e12", "", "abc", "1e-320", "0x10", "1,5", "--", "99999999999999999999",
           "\xff", "\u00fc", "3.5", "-0", "1e308", "2147483648", "18446744073709551616"]
# Flags that keep a valid run short, so a generated run that happens to be valid ends quickly.
short = ["--entrain", "0", "--eval", "0.05"]
templates = {
    "rollout": ["--entrain", "--eval", "--treadmill", "--seed", "--set", "--terrain", "--disable"],
    "analyze": ["--store", "--study", "--jitter"],
    "optimize": ["--budget", "--initial", "--seed", "--batch", "--timeout", "--acq", "--design", "--liar", "--cost-transform"],
    "reproduce": ["--seeds", "--first-seed", "--workers", "--jitter"],
    "export": ["--store", "--study", "--format"],  # no --out: a generated run never writes a file
}
bad = 0


def ends_well(args, cwd, what):
    """Runs one command line; False (and says why) on a hang, a crash, exit 1, or exit 2 without a message."""
    try:
        p = subprocess.run(args, capture_output=True, timeout=30, cwd=cwd)
    except subprocess.TimeoutExpired:
        print(f"HANG: {what}")
        return False
    if p.returncode not in (0, 2) or (p.returncode == 2 and not p.stderr.strip()):
        print(f"exit {p.returncode}: {what}\n  stderr: {p.stderr.decode(errors='replace')[:300]}")
        return False
    return True

with tempfile.TemporaryDirectory() as tmp:
    for i in range(n):
        command = rng.choice(list(templates))
        flags = rng.sample(templates[command], k=rng.randint(1, min(3, len(templates[command]))))
        args = [f"{bin_dir}/cpgmatch", command]
        if command == "rollout":
            args += short
        if command == "optimize":
            args += ["--space", "/nonexistent-space.yaml", "--objective-cmd", "echo 1"]
        for f in flags:
            value = rng.choice(garbage)
            if f == "--set":
                value = rng.choice(["hip_offset", "overswing", "nope", ""]) + "=" + value
            if f == "--terrain":
                value = rng.choice(["rough:", "step:", "shift:", "flat", ""]) + value
            args += [f, value]
        if command in ("reproduce",):
            args += ["--config", "/nonexistent-study.yaml"]  # never start a real study from the fuzz
        bad += not ends_well(args, tmp, str(args))

# Rollout settings files (`cpgmatch rollout --settings`): one to three keys of configs/rollout.yaml set to
# garbage, a list or a map. Every number in that file has a range (common/src/rollout.cpp).
settings_keys = {
    "": ["entrain_s", "eval_s"],
    "controller": ["coupling_gain_per_s", "control_rate_hz", "startup_ramp_s", "gait"],
    "controller.feedback": ["late_touchdown_phase_rate", "late_touchdown_max_wait_s", "late_toeoff_phase_rate",
                            "reflex_duration_s", "reflex_hip_passive_s", "reflex_knee_flexion_rad",
                            "etd_min_airborne_s", "etd_min_knee_flexion_fraction", "eto_min_stance_fraction",
                            "early_touchdown", "reflex_needs_girdle_support"],
    "contact_sensor": ["threshold_n", "release_threshold_n", "min_stable_s", "poll_rate_hz", "noise_std_n",
                       "latency_s"],
    "cost": ["min_distance_m", "fall_max_abs_pitch_rad", "fall_min_height_m", "fall_cost_margin", "contact_cap",
             "fall_cost_per_lost_fraction"],
    "cost.weights": ["feedback", "distance", "pitch", "contact", "periodicity"],
}
settings_values = [v for v in garbage if v not in ("", "\xff")] + ["[1, 2]", "{a: 1}", "true", "~", "0.5", "1e-9"]
n_settings = max(1, n // 3)
with tempfile.TemporaryDirectory() as tmp:
    for i in range(n_settings):
        tree = {}  # nested sections, each key once (a repeated key is refused before any value is read)
        for _ in range(rng.randint(1, 3)):
            section = rng.choice(list(settings_keys))
            node = tree
            for name in section.split(".") if section else []:
                node = node.setdefault(name, {})
            node[rng.choice(settings_keys[section])] = rng.choice(settings_values)

        def emit(node, depth=0):
            for k, v in node.items():
                if isinstance(v, dict):
                    yield f"{'  ' * depth}{k}:"
                    yield from emit(v, depth + 1)
                else:
                    yield f"{'  ' * depth}{k}: {v}"

        path = os.path.join(tmp, f"settings-{i}.yaml")
        with open(path, "w", encoding="utf-8") as f:
            f.write("\n".join(emit(tree)) + "\n")
        args = [f"{bin_dir}/cpgmatch", "rollout", "--settings", path] + short
        with open(path, encoding="utf-8") as f:
            bad += not ends_well(args, tmp, f"settings {f.read()!r}")
print(f"cli fuzz: {n} generated command lines and {n_settings} settings files, {bad} bad outcomes")
sys.exit(1 if bad else 0)
