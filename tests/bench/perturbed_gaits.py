#!/usr/bin/env python3
"""Falls of good gaits on perturbed ground, with and without the elastic feedback.

Usage: tests/bench/perturbed_gaits.py BUILD_DIR TERRAINS [SEEDS=6] [GAIT...]
  TERRAINS  comma-separated `cpgmatch rollout --terrain` specs, e.g. rough:0.003,shift:0.02@5,step:0.05@1.5
  GAIT      a parameter YAML (configs/params/*.yaml) or a study's analysis.json (its best gait);
            default: configs/params/matched-trot.yaml
Each gait runs on each terrain with seeds 0..SEEDS-1, feedback on and off (`--no-feedback`), two rollouts
at a time. Prints falls with / without per terrain and per gait. Run by hand; the numbers in
docs/model.md ("Feedback on random gaits") came from the matched trot and the best gaits of
`cpgmatch reproduce --seeds 5` (seed-*/analysis.json).
"""
import concurrent.futures as cf
import json
import pathlib
import subprocess
import sys

if len(sys.argv) < 3:
    sys.exit(__doc__)
build = sys.argv[1]
terrains = sys.argv[2].split(",")
seeds = int(sys.argv[3]) if len(sys.argv) > 3 else 6
sources = sys.argv[4:] or [str(pathlib.Path(__file__).resolve().parents[2] / "configs/params/matched-trot.yaml")]


def gait_flags(source):
    """`cpgmatch rollout` flags that select the gait in `source`."""
    if source.endswith(".json"):
        params = json.load(open(source))["best"]["params"]
        return [arg for name, value in params.items() for arg in ("--set", f"{name}={value}")]
    return ["--params", source]


gaits = {f"{i}:{pathlib.Path(s).parent.name if s.endswith('.json') else pathlib.Path(s).stem}": gait_flags(s)
         for i, s in enumerate(sources)}


def run(job):
    gait, terrain, seed, feedback = job
    cmd = [f"{build}/bin/cpgmatch", "rollout", "--json", "--terrain", terrain, "--seed", str(seed)] + gaits[gait]
    if not feedback:
        cmd.append("--no-feedback")
    return job, json.loads(subprocess.run(cmd, capture_output=True, text=True, check=True).stdout)["fell"]


jobs = [(g, t, s, fb) for g in gaits for t in terrains for s in range(seeds) for fb in (True, False)]
falls = {}
with cf.ThreadPoolExecutor(2) as pool:
    for done, ((g, t, _, fb), fell) in enumerate(pool.map(run, jobs), 1):
        falls[(g, t, fb)] = falls.get((g, t, fb), 0) + int(fell)
        print(f"\r{done}/{len(jobs)} rollouts", end="", file=sys.stderr, flush=True)
print(file=sys.stderr)
for t in terrains:
    with_fb = sum(falls[(g, t, True)] for g in gaits)
    without = sum(falls[(g, t, False)] for g in gaits)
    per_gait = " ".join(f"{g} {falls[(g, t, True)]}/{falls[(g, t, False)]}" for g in gaits)
    print(f"{t}: falls with feedback {with_fb} / without {without} (of {seeds * len(gaits)} each); per gait: {per_gait}")
