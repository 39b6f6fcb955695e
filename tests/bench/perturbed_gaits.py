#!/usr/bin/env python3
"""Falls and stalls of good gaits on perturbed ground, with and without the elastic feedback.

Usage: tests/bench/perturbed_gaits.py BUILD_DIR TERRAINS [SEEDS=6] [GAIT...] [-- FLAG...]
  TERRAINS  comma-separated `cpgmatch rollout --terrain` specs, e.g. rough:0.003,shift:0.02@5,step:0.05@1.5
  GAIT      a parameter YAML (configs/params/*.yaml) or a study's analysis.json (its best gait);
            default: configs/params/matched-trot.yaml
  FLAG      extra `cpgmatch rollout` flags for the feedback-on rollouts only, e.g.
            `-- --disable etd` or `-- --settings variant.yaml` (a controller variant against the open loop);
            not --entrain/--eval: the open-loop rollouts would not get them, and a stall is judged on 10 s
Each gait runs on each terrain with seeds 0..SEEDS-1, feedback on and off (`--no-feedback`), two rollouts
at a time. A rollout that did not fall but covered less than 0.5 m in the evaluated 10 s (it walked into a
step it cannot climb, or stumbles in place) is counted as stalled, apart from the falls: standing at a step
is not a fall, but it is not walking either. Run by hand; the numbers in docs/model.md ("Feedback on
perturbed ground") came from the matched trot and the best gaits of `cpgmatch reproduce --seeds 10`.
"""
import concurrent.futures as cf
import json
import pathlib
import subprocess
import sys

args = sys.argv[1:]
extra = args[args.index("--") + 1:] if "--" in args else []
args = args[:args.index("--")] if "--" in args else args
if len(args) < 2:
    sys.exit(__doc__)
build = args[0]
terrains = args[1].split(",")
seeds = int(args[2]) if len(args) > 2 else 6
sources = args[3:] or [str(pathlib.Path(__file__).resolve().parents[2] / "configs/params/matched-trot.yaml")]
STALLED_BELOW_M = 0.5


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
    cmd += extra if feedback else ["--no-feedback"]
    result = json.loads(subprocess.run(cmd, capture_output=True, text=True, check=True).stdout)
    if result["fell"]:
        return job, "fell"
    return job, "stalled" if result["distance_m"] < STALLED_BELOW_M else "walked"


jobs = [(g, t, s, fb) for g in gaits for t in terrains for s in range(seeds) for fb in (True, False)]
outcomes = {}
with cf.ThreadPoolExecutor(2) as pool:
    for done, ((g, t, _, fb), outcome) in enumerate(pool.map(run, jobs), 1):
        outcomes.setdefault((g, t, fb), []).append(outcome)
        print(f"\r{done}/{len(jobs)} rollouts", end="", file=sys.stderr, flush=True)
print(file=sys.stderr)


def count(terrain, feedback, outcome, gait=None):
    return sum(outcomes[(g, terrain, feedback)].count(outcome) for g in gaits if gait in (None, g))


label = "feedback" + (f" ({' '.join(extra)})" if extra else "")
for t in terrains:
    print(f"{t}, of {seeds * len(gaits)} rollouts each: {label} falls {count(t, True, 'fell')} stalls "
          f"{count(t, True, 'stalled')} / open loop falls {count(t, False, 'fell')} "
          f"stalls {count(t, False, 'stalled')}")
    print("  per gait, falls+stalls with / without: " +
          " ".join(f"{g} {count(t, True, 'fell', g)}+{count(t, True, 'stalled', g)}/"
                   f"{count(t, False, 'fell', g)}+{count(t, False, 'stalled', g)}" for g in gaits))
