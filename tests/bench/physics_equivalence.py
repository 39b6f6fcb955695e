#!/usr/bin/env python3
"""Benchmark: does a new simulator binary compute the same physics as an old one, and how much faster is it?

Runs the shipped presets and N random gaits of the paper's space (Morti's search_space in
configs/robots/morti/robot.yaml, uniform, seeded) through `cpgmatch rollout --json` of both binaries, in
alternation (old, new, old, new, ...) so that both see the same machine load. Prints, per gait, both costs
and outcomes, then the median and max absolute and relative cost difference, every gait whose outcome
(completed / fell) differs, and the CPU time per rollout of each binary (user + system time of the rollout
process, median), with the ratio. Writes the rows as JSON with --json-out.

Usage: tests/bench/physics_equivalence.py OLD_CPGMATCH NEW_CPGMATCH [--gaits 200] [--seed 1] [--repeats 1] [--jobs 1]
                                          [--json-out FILE]
"""
import argparse
import json
import os
import random
import resource
import statistics
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

# The paper's six optimised parameters and their bounds (configs/robots/morti/robot.yaml, search_space);
# frequency and knee amplitude stay at the defaults, as in the paper.
SPACE = {
    "hip_offset": (-0.35, 0.35),
    "hip_amplitude": (0.1, 0.65),
    "duty_factor_front": (0.3, 0.75),
    "duty_factor_hind": (0.3, 0.75),
    "knee_phase_shift": (0.0, 0.5),
    "overswing": (0.0, 0.5),
}


def run(binary, args):
    """One rollout: (report, CPU seconds of the rollout process)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    out = subprocess.run([binary, "rollout", "--json", *args], cwd=ROOT, check=True, capture_output=True, text=True).stdout
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return json.loads(out), cpu


def gaits(count, seed, repeats):
    rng = random.Random(seed)
    for r in range(repeats):
        for preset in ("default", "matched-trot", "unmatched"):
            yield preset if r == 0 else f"{preset}#{r + 1}", ["--params", f"configs/params/{preset}.yaml"]
    for i in range(count):
        sets = [f"{name}={rng.uniform(lo, hi):.6f}" for name, (lo, hi) in SPACE.items()]
        yield f"random-{i}", ["--set", *sets]


def compare(old, new, name, args):
    # Alternation inside one job: both binaries run back to back on the same core load.
    (a, ca), (b, cb) = run(old, args), run(new, args)
    return {"gait": name, "args": args, "old_cost": a["cost"], "new_cost": b["cost"], "old_outcome": a["outcome"],
            "new_outcome": b["outcome"], "old_cpu_s": ca, "new_cpu_s": cb}


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("old")
    p.add_argument("new")
    p.add_argument("--gaits", type=int, default=200)
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--repeats", type=int, default=1, help="runs of each preset (more samples for the timing)")
    p.add_argument("--jobs", type=int, default=1, help="gaits compared at once (CPU times are then per core)")
    p.add_argument("--json-out")
    a = p.parse_args()
    jobs = list(gaits(a.gaits, a.seed, a.repeats))
    rows = []
    with ThreadPoolExecutor(max_workers=a.jobs) as pool:
        for i, row in enumerate(pool.map(lambda j: compare(a.old, a.new, *j), jobs), 1):
            rows.append(row)
            print(f"[{i}/{len(jobs)}] {row['gait']}: old {row['old_cost']:.6f} ({row['old_outcome']}), "
                  f"new {row['new_cost']:.6f} ({row['new_outcome']})", file=sys.stderr, flush=True)
    diffs = [abs(r["new_cost"] - r["old_cost"]) for r in rows]
    rel = [d / max(abs(r["old_cost"]), 1e-12) for d, r in zip(diffs, rows)]
    changed = [r for r in rows if r["old_outcome"] != r["new_outcome"]]
    print(f"rollouts: {len(rows)} (3 presets x {a.repeats} + {a.gaits} random gaits, seed {a.seed})")
    print(f"|cost difference|: median {statistics.median(diffs):.3g}, max {max(diffs):.3g} "
          f"(relative: median {statistics.median(rel):.3g}, max {max(rel):.3g})")
    worst = max(rows, key=lambda r: abs(r["new_cost"] - r["old_cost"]))
    print(f"largest difference: {worst['gait']} old {worst['old_cost']:.6f} new {worst['new_cost']:.6f}")
    falls_old = sum(r["old_outcome"] == "fell" for r in rows)
    falls_new = sum(r["new_outcome"] == "fell" for r in rows)
    print(f"falls: old {falls_old}, new {falls_new}; outcomes that differ: {len(changed)}")
    for r in changed:
        print(f"  {r['gait']}: old {r['old_outcome']} {r['old_cost']:.4f}, new {r['new_outcome']} {r['new_cost']:.4f}")
    # Timing on the rollouts that ran their 20 s on both sides (a fall ends a rollout early).
    full = [r for r in rows if r["old_outcome"] == r["new_outcome"] == "completed"]
    old_cpu = statistics.median(r["old_cpu_s"] for r in full)
    new_cpu = statistics.median(r["new_cpu_s"] for r in full)
    ratios = sorted(r["old_cpu_s"] / r["new_cpu_s"] for r in full)
    print(f"CPU s per completed rollout (process: start-up included, median of {len(full)}): old {old_cpu:.3f}, "
          f"new {new_cpu:.3f}, ratio {old_cpu / new_cpu:.2f}x (per-pair ratio median {statistics.median(ratios):.2f}, "
          f"min {ratios[0]:.2f}, max {ratios[-1]:.2f})")
    if a.json_out:
        with open(a.json_out, "w") as f:
            json.dump(rows, f, indent=1)


if __name__ == "__main__":
    main()
