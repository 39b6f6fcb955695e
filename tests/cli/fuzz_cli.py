#!/usr/bin/env python3
"""Fuzz the command line: a few hundred generated argument lists (fixed seed) for `cpgmatch rollout`,
`analyze`, `optimize` and `study run`. Each must end with exit 0 (valid input) or 2 (bad input, with a
message on stderr), never a crash, a signal, exit 1 or a hang (each run is time-bounded).
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
}
bad = 0
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
        try:
            p = subprocess.run(args, capture_output=True, timeout=30, cwd=tmp)
        except subprocess.TimeoutExpired:
            print(f"HANG: {args}")
            bad += 1
            continue
        if p.returncode not in (0, 2) or (p.returncode == 2 and not p.stderr.strip()):
            print(f"exit {p.returncode}: {args}\n  stderr: {p.stderr.decode(errors='replace')[:300]}")
            bad += 1
print(f"cli fuzz: {n} generated command lines, {bad} bad outcomes")
sys.exit(1 if bad else 0)
