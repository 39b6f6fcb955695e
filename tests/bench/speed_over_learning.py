#!/usr/bin/env python3
"""Why speed does not rise over a study: measurements on a `cpgmatch reproduce` folder (issue 26).

Usage: tests/bench/speed_over_learning.py BUILD_DIR REPRODUCE_DIR [--traces N]

Per seed (seed-*/trials.jsonl): Spearman rho(J_feedback, speed) over non-fallen rollouts, the mean speed per
window (1-15, 16-50, 51-100, 101-150), falls in the initial design, the best rollout's speed and how many of
its six parameters sit within 2% of a search bound. With --traces N (default 3): re-runs the best gait of every
seed and the initial design's gaits of the first N seeds with `cpgmatch rollout --trace` and compares each
leg's measured duty factor (fraction of the evaluation in contact) with the commanded one.
Standard library only.
"""
import csv
import json
import math
import os
import statistics
import subprocess
import sys
import tempfile

BOUNDS = {"hip_offset": (-0.35, 0.35), "hip_amplitude": (0.1, 0.65), "duty_factor_front": (0.3, 0.75),
          "duty_factor_hind": (0.3, 0.75), "knee_phase_shift": (0.0, 0.5), "overswing": (0.0, 0.5)}
WINDOWS = [(1, 15), (16, 50), (51, 100), (101, 150)]


def ranks(v):
    order = sorted(range(len(v)), key=lambda i: v[i])
    r = [0.0] * len(v)
    i = 0
    while i < len(order):
        j = i
        while j + 1 < len(order) and v[order[j + 1]] == v[order[i]]:
            j += 1
        for k in range(i, j + 1):
            r[order[k]] = (i + j) / 2 + 1
        i = j + 1
    return r


def pearson(a, b):
    ma, mb = statistics.fmean(a), statistics.fmean(b)
    sab = sum((x - ma) * (y - mb) for x, y in zip(a, b))
    saa = sum((x - ma) ** 2 for x in a)
    sbb = sum((y - mb) ** 2 for y in b)
    return sab / math.sqrt(saa * sbb) if saa > 0 and sbb > 0 else float("nan")


def spearman(a, b):
    return pearson(ranks(a), ranks(b)) if len(a) >= 3 else float("nan")


def mean_sd(v):
    v = [x for x in v if not math.isnan(x)]
    if not v:
        return "-"
    return f"{statistics.fmean(v):.3f} +- {statistics.stdev(v):.3f}" if len(v) > 1 else f"{v[0]:.3f}"


def load(seed_dir):
    rows = [json.loads(line) for line in open(os.path.join(seed_dir, "trials.jsonl"))]
    rows.sort(key=lambda r: r["index"])
    return rows


def walked(r):
    return r.get("ok") and not r["result"].get("fell")


def duty_factors(cpgmatch, params):
    """Measured fraction of the evaluation (last 10 s) each leg is in contact, from a traced rollout."""
    with tempfile.NamedTemporaryFile(suffix=".csv", delete=False) as f:
        trace = f.name
    args = [cpgmatch, "rollout", "--json", "--trace", trace]
    for k, v in params.items():
        args += ["--set", f"{k}={v}"]
    out = json.loads(subprocess.run(args, check=True, capture_output=True, text=True).stdout)
    contact = {leg: [] for leg in ("FL", "FR", "HL", "HR")}
    with open(trace) as f:
        for row in csv.DictReader(f):
            if float(row["time_s"]) < 10.0:
                continue
            for leg in contact:
                contact[leg].append(int(row[f"{leg}_contact"]))
    os.unlink(trace)
    if out["fell"]:
        return None
    return {leg: statistics.fmean(c) for leg, c in contact.items() if c}, out["mean_speed_mps"]


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    build, folder = sys.argv[1], sys.argv[2]
    traces = int(sys.argv[sys.argv.index("--traces") + 1]) if "--traces" in sys.argv else 3
    cpgmatch = os.path.join(build, "bin", "cpgmatch")
    seeds = sorted((d for d in os.listdir(folder) if d.startswith("seed-")), key=lambda d: int(d[5:]))
    rho_fb_speed, windows, falls_initial, best_speed, best_at_bound, initial_speed, initial_speed_max = [], [], [], [], [], [], []
    bound_counts = {k: 0 for k in BOUNDS}
    rho_speed_contact, clean_fastest, fast, fast_stumbling = [], [], 0, 0
    duty = []  # (commanded, measured, speed, best?)
    for n, seed in enumerate(seeds):
        rows = load(os.path.join(folder, seed))
        ok = [r for r in rows if walked(r)]
        fb = [r["result"]["terms"]["feedback"] for r in ok]
        v = [r["result"]["mean_speed_mps"] for r in ok]
        rho_fb_speed.append(spearman(fb, v))
        # Fast gaits and clean contacts: J_contact counts contact phases beyond the two of a clean step.
        contact = [r["result"]["terms"]["contact"] for r in ok]
        rho_speed_contact.append(spearman(v, contact))
        clean_fastest.append(max((s_ for s_, c in zip(v, contact) if c < 0.05), default=math.nan))
        fast += sum(1 for s_ in v if s_ > 0.45)
        fast_stumbling += sum(1 for s_, c in zip(v, contact) if s_ > 0.45 and c >= 0.3)
        windows.append([statistics.fmean([r["result"]["mean_speed_mps"] for r in ok if a <= r["index"] + 1 <= b] or [math.nan])
                        for a, b in WINDOWS])
        falls_initial.append(sum(1 for r in rows if r["index"] < 15 and r["result"].get("fell")))
        init = [r["result"]["mean_speed_mps"] for r in ok if r["index"] < 15]
        initial_speed.append(statistics.fmean(init))
        initial_speed_max.append(max(init))
        best = min((r for r in rows if r.get("ok")), key=lambda r: r["cost"])
        best_speed.append(best["result"]["mean_speed_mps"])
        at = [k for k, (lo, hi) in BOUNDS.items() if min(best["params"][k] - lo, hi - best["params"][k]) <= 0.02 * (hi - lo)]
        best_at_bound.append(len(at))
        for k in at:
            bound_counts[k] += 1
        gaits = [(best["params"], True)] + ([(r["params"], False) for r in rows if r["index"] < 15] if n < traces else [])
        for params, is_best in gaits:
            got = duty_factors(cpgmatch, params)
            if got is None:
                continue
            measured, speed = got
            for leg, d in measured.items():
                cmd = params["duty_factor_front" if leg[0] == "F" else "duty_factor_hind"]
                duty.append((cmd, d, speed, is_best))
        print(f"{seed}: rho(J_feedback, speed) {rho_fb_speed[-1]:+.2f}; window speeds "
              + " / ".join(f"{w:.2f}" for w in windows[-1])
              + f"; initial falls {falls_initial[-1]}; best {best['index'] + 1} at {best_speed[-1]:.2f} m/s, at a bound: {at}")
    print(f"\nrho(J_feedback, speed) within studies: {mean_sd(rho_fb_speed)} (positive on {sum(r > 0 for r in rho_fb_speed)} of {len(seeds)})")
    print(f"rho(speed, J_contact) within studies: {mean_sd(rho_speed_contact)}; fastest gait with J_contact < 0.05: "
          f"{mean_sd(clean_fastest)} m/s; of {fast} rollouts faster than 0.45 m/s, {fast_stumbling} have J_contact >= 0.3")
    for i, (a, b) in enumerate(WINDOWS):
        print(f"mean speed, rollouts {a}-{b}: {mean_sd([w[i] for w in windows])} m/s")
    print(f"initial design: mean speed of its gaits that walked {mean_sd(initial_speed)} m/s, fastest {mean_sd(initial_speed_max)} m/s; "
          f"falls {mean_sd(falls_initial)} of 15")
    print(f"best gaits: speed {mean_sd(best_speed)} m/s; parameters within 2% of a bound {mean_sd(best_at_bound)} of 6; "
          f"by parameter: {bound_counts}")
    if duty:
        cmd = [c for c, _, _, _ in duty]
        meas = [m for _, m, _, _ in duty]
        print(f"duty factors over {len(duty)} legs of {len(duty) // 4} traced gaits that walked: commanded "
              f"{min(cmd):.2f}-{max(cmd):.2f}, measured {min(meas):.2f}-{max(meas):.2f}; "
              f"rho(commanded, measured) {spearman(cmd, meas):+.2f}; slope of measured on commanded "
              f"{pearson(cmd, meas) * statistics.stdev(meas) / statistics.stdev(cmd):.2f}")
        sp = [(m, s) for _, m, s, _ in duty]
        print(f"rho(measured duty factor, speed) {spearman([m for m, _ in sp], [s for _, s in sp]):+.2f}; "
              f"rho(commanded duty factor, speed) {spearman(cmd, [s for _, _, s, _ in duty]):+.2f}")


if __name__ == "__main__":
    main()
