#!/usr/bin/env python3
"""Falls with and without the elastic feedback over uniform random points of the paper's space.

Usage: tests/bench/feedback_ablation.py BUILD_DIR [N=100] [TERRAIN=flat] [--repeats K] [--save FILE.json]
                                         [--load FILE.json] [--plot FILE.png] [extra `cpgmatch rollout` flags...]
(N and TERRAIN are positional and come first; the options follow them.)
Runs 2 x N x K rollouts (feedback on / off, same points; repeat r of point i has rollout seed i + 1000 r,
so K = 1 is seed = point index as before) two at a time and prints falls and medians of the cost terms over
the rollouts that did not fall. The seed sets the sensor noise (and the ground, when rough), so repeats say
how much of a point's outcome is chance. It also prints the paired comparison: rollouts that fall only
with feedback against only without, with an exact two-sided sign test (McNemar) on those discordant pairs;
the same per point (a point counts as worse with feedback when it falls with feedback under more of its K
seeds than without: the seeds of one point are far from independent); and both split by the commanded
touchdown angle (hip offset + amplitude) and by how well the hips follow the pattern open loop
(`hip_tracking_rms_rad` of the rollout without feedback). The split edges are descriptive: they were chosen
after looking at the data (docs/model.md, "Which random gaits the feedback breaks").
--load analyses a run saved with --save (N and TERRAIN then only label it; nothing is run).
--plot draws the falls with and without feedback per touchdown-angle bin (gnuplot, PNG and SVG).
Points come from a fixed RNG seed (42) so runs are comparable across model changes. Run by hand (about
50-70 s for N = 100, K = 1 on 2 cores).
"""
import concurrent.futures as cf
import json
import math
import os
import random
import statistics as st
import subprocess
import sys
import tempfile

build = sys.argv[1]
n = int(sys.argv[2]) if len(sys.argv) > 2 else 100
terrain = sys.argv[3] if len(sys.argv) > 3 else "flat"
extra = sys.argv[4:]


def take_option(name):
    """Removes `name VALUE` from the extra flags and returns VALUE (None if absent)."""
    if name not in extra:
        return None
    at = extra.index(name)
    value = extra[at + 1]
    del extra[at:at + 2]
    return value


repeats = int(take_option("--repeats") or 1)
save = take_option("--save")
plot = take_option("--plot")
load = take_option("--load")
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


if load:  # analyse (and plot) a run saved with --save instead of running it again
    with open(load) as saved:
        entries = json.load(saved)
    jobs = [(e["point"], fb, e["seed"]) for e in entries for fb in (True, False)]
    results = [e[key] for e in entries for key in ("feedback", "open_loop")]
    n = len({tuple(sorted(e["point"].items())) for e in entries})
    repeats = len(entries) // n
else:
    jobs = [(p, fb, i + 1000 * r) for r in range(repeats) for i, p in enumerate(points) for fb in (True, False)]
    with cf.ThreadPoolExecutor(2) as pool:
        results = list(pool.map(run, jobs))
for label, want in (("feedback on ", True), ("feedback off", False)):
    rs = [r for r, (_, fb, _) in zip(results, jobs) if fb == want]
    walked = [r for r in rs if not r["fell"]]
    med = lambda k: st.median(r["terms"][k] for r in walked) if walked else float("nan")
    print(f"{terrain} {label}: falls {sum(r['fell'] for r in rs)}/{len(rs)}; non-fallen medians: "
          f"J_feedback {med('feedback'):.3f} J_distance {med('distance'):.3f} J_contact {med('contact'):.3f} "
          f"J_periodicity {med('periodicity'):.3f}")


def sign_test_p(a, b):
    """Exact two-sided binomial test of a successes against b, p = 1/2 (McNemar on discordant pairs)."""
    n, k = a + b, min(a, b)
    if n == 0:
        return 1.0
    tail = sum(math.comb(n, j) for j in range(k + 1)) / 2 ** n
    return min(1.0, 2 * tail)


pairs = list(zip(results[0::2], results[1::2], jobs[0::2]))


def counts(part):
    """(falls with feedback, falls without, rollouts falling only with, only without) over (on, off, job) pairs."""
    return (sum(on["fell"] for on, _, _ in part), sum(off["fell"] for _, off, _ in part),
            sum(on["fell"] and not off["fell"] for on, off, _ in part),
            sum(off["fell"] and not on["fell"] for on, off, _ in part))


if save:  # every pair, for tracing single points with `cpgmatch rollout --seed SEED --set ...`
    with open(save, "w") as out:
        json.dump([{"seed": job[2], "point": job[0], "feedback": on, "open_loop": off} for on, off, job in pairs],
                  out, indent=1)
falls_with, _, only_with, only_without = counts(pairs)
print(f"{terrain} paired over {len(pairs)} rollouts ({n} points x {repeats} seeds): fall only with feedback "
      f"{only_with}, only without {only_without}, both {falls_with - only_with}; "
      f"sign test p = {sign_test_p(only_with, only_without):.3g}")
for r in range(repeats):
    falls_with, falls_without, _, _ = counts(pairs[r * n:(r + 1) * n])
    print(f"  seeds i + {1000 * r}: falls with feedback {falls_with}, without {falls_without}")
print("  fall only with feedback (seed: fall time s): " +
      ", ".join(f"{job[2]}: {on['fall_time_s']:.1f}" for on, off, job in pairs if on["fell"] and not off["fell"]))


def print_split(title, key, edges):
    """Falls with / without feedback, only with / only without (rollouts, then points), binned by key."""
    print(f"  by {title}: rollouts, falls with / without feedback, only with / only without (sign test p); "
          f"points worse / better with feedback (p)")
    rows = []
    for lo, hi in zip(edges, edges[1:]):
        part = [(on, off, job) for on, off, job in pairs if lo <= key(on, off, job) < hi]
        falls_with, falls_without, only_with, only_without = counts(part)
        worse, better = points_worse_better(part)
        print(f"    [{lo:+.2f}, {hi:+.2f}): {len(part):3d} rollouts, falls {falls_with:3d} / {falls_without:3d}, "
              f"only {only_with:3d} / {only_without:3d} (p = {sign_test_p(only_with, only_without):.2g}); "
              f"points {worse} / {better} (p = {sign_test_p(worse, better):.2g})")
        rows.append((lo, hi, len(part), falls_with, falls_without))
    return rows


def points_worse_better(part):
    """Points (over their seeds) that fall more often with feedback than without, and fewer times."""
    net = {}
    for on, off, job in part:
        point = tuple(sorted(job[0].items()))
        net[point] = net.get(point, 0) + int(on["fell"]) - int(off["fell"])
    return sum(v > 0 for v in net.values()), sum(v < 0 for v in net.values())


worse, better = points_worse_better(pairs)
print(f"  per point over its {repeats} seed(s): worse with feedback {worse}, better {better}; "
      f"sign test p = {sign_test_p(worse, better):.3g}")
inf = float("inf")
# A rollout that fell during the start-up ramp has no tracking (null): it is left out of that split.
print_split("open-loop hip tracking (RMS of command minus hip angle, rad)",
            lambda on, off, job: off["hip_tracking_rms_rad"] if off["hip_tracking_rms_rad"] is not None else -inf,
            [0.0, 0.10, 0.15, 0.25, inf])
# Where the pattern puts the foot down: hip offset + amplitude, rad (+ forward; about -0.1 puts the toe under
# the hip when standing).
by_touchdown = print_split("commanded touchdown angle (hip offset + amplitude, rad)",
            lambda on, off, job: job[0]["hip_offset"] + job[0]["hip_amplitude"], [-inf, 0.15, 0.30, 0.45, 0.60, inf])


def draw(rows, path):
    """Grouped bars: share of rollouts that fell with and without feedback, per touchdown-angle bin."""
    with tempfile.NamedTemporaryFile("w", suffix=".dat", delete=False) as data:
        for lo, hi, count, with_fb, without in rows:
            label = f"{lo:.2f}-{hi:.2f}"
            if lo == -inf:
                label = f"< {hi:.2f}"
            elif hi == inf:
                label = f">= {lo:.2f}"
            data.write(f'"{label}\\n({count})" {100 * with_fb / max(count, 1):.2f} {100 * without / max(count, 1):.2f}\n')
    stem = os.path.splitext(path)[0]
    script = f"""
set style data histograms; set style histogram clustered gap 1; set style fill solid 0.8 border -1
set ylabel 'rollouts that fell, %'; set xlabel 'commanded touchdown angle, rad (rollouts)'; set grid ytics
set title 'Falls with and without feedback, {n} random points x {repeats} seed(s), {terrain}' noenhanced
set key left top; set yrange [0:*]; set bmargin 5; set xlabel offset 0,-1
"""
    plot_cmd = f"plot '{data.name}' u 2:xtic(1) t 'feedback on' lc rgb '#1b9e77', '' u 3 t 'open loop' lc rgb '#d95f02'\n"
    for terminal, out in (("pngcairo size 900,500 noenhanced", stem + ".png"), ("svg size 900,500 noenhanced", stem + ".svg")):
        subprocess.run(["gnuplot"], input=f"set terminal {terminal}\nset output '{out}'\n{script}{plot_cmd}",
                       text=True, check=True)
    os.unlink(data.name)
    print(f"plot: {stem}.png, {stem}.svg")


if plot:
    draw(by_touchdown, plot)
