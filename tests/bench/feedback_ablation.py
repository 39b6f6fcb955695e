#!/usr/bin/env python3
"""Falls with and without the elastic feedback over uniform random points of the paper's space.

Usage: tests/bench/feedback_ablation.py BUILD_DIR [N=100] [TERRAIN=flat] [extra `cpgmatch rollout` flags...]
Runs 2 x N rollouts (feedback on / off, same points, seed = point index) two at a time and prints falls
and medians of the cost terms over the rollouts that did not fall. Points come from a fixed RNG seed (42)
so runs are comparable across model changes. Run by hand (about 70 s for N = 100 on 2 cores).
"""
import concurrent.futures as cf
import json
import random
import statistics as st
import subprocess
import sys

build = sys.argv[1]
n = int(sys.argv[2]) if len(sys.argv) > 2 else 100
terrain = sys.argv[3] if len(sys.argv) > 3 else "flat"
extra = sys.argv[4:]
binary = f"{build}/bin/cpgmatch"
space = [("hip_offset", -0.35, 0.35), ("hip_amplitude", 0.1, 0.65), ("duty_factor_front", 0.3, 0.75),
         ("duty_factor_hind", 0.3, 0.75), ("knee_phase_shift", 0.0, 0.5), ("overswing", 0.0, 0.5)]
rng = random.Random(42)
points = [{name: rng.uniform(lo, hi) for name, lo, hi in space} for _ in range(n)]


def run(job):
    point, feedback, seed = job
    cmd = [binary, "rollout", "--json", "--terrain", terrain, "--seed", str(seed)] + extra
    for name, value in point.items():
        cmd += ["--set", f"{name}={value}"]
    if not feedback:
        cmd.append("--no-feedback")
    return json.loads(subprocess.run(cmd, capture_output=True, text=True, check=True).stdout)


jobs = [(p, fb, i) for i, p in enumerate(points) for fb in (True, False)]
with cf.ThreadPoolExecutor(2) as pool:
    results = list(pool.map(run, jobs))
for label, want in (("feedback on ", True), ("feedback off", False)):
    rs = [r for r, (_, fb, _) in zip(results, jobs) if fb == want]
    walked = [r for r in rs if not r["fell"]]
    med = lambda k: st.median(r["terms"][k] for r in walked) if walked else float("nan")
    print(f"{terrain} {label}: falls {sum(r['fell'] for r in rs)}/{len(rs)}; non-fallen medians: "
          f"J_feedback {med('feedback'):.3f} J_distance {med('distance'):.3f} J_contact {med('contact'):.3f} "
          f"J_periodicity {med('periodicity'):.3f}")
