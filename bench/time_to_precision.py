#!/usr/bin/env python3
"""Time to precision: plain Monte Carlo against importance sampling of launch directions.

Runs a scenario (default: the demo) twice with settings.precision and no targets, so that both
runs do exactly --batches batches of the groups' samples: once plain, once with
direction_importance (its pilot batch included in its time). For every figure with a nonzero
mean it prints the standard error and the wall time each run would need for a 5 % relative
standard error, extrapolated as T5 = T * (se / (0.05 * mean))^2 (se ~ 1/sqrt(n)), and the ratio
of the two: the gain in figure of merit 1/(se^2 T). Figures: the HFD half band (target 1 m
instead of 5 %), each building's expected impacts and penetrations, the building and left_site
outcome counts. docs/benchmarks.md, "Time to precision".

    bench/time_to_precision.py [--cli build/cli/fragsim] [--scenario examples/demo/scenario.json]
                               [--batches 10] [--threads 2] [--seed N] [--cells 24x72]
                               [--defensive 0.3]
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile


def run(cli, scenario, precision, threads, seed, out):
    s = json.loads(json.dumps(scenario))
    s["settings"]["precision"] = precision
    s["settings"]["record_fragments"] = False
    s["settings"]["threads"] = threads
    if seed is not None:
        s["settings"]["seed"] = seed
    path = os.path.join(out, "scenario.json")
    with open(path, "w") as f:
        json.dump(s, f)
    subprocess.run([cli, "run", path, "--out", out, "--quiet"], check=True)
    with open(os.path.join(out, "summary.json")) as f:
        return json.load(f)


def figures(summary):
    out = {}
    lo, hi = summary["hazardous_fragment_distance_band_m"]
    out["HFD half band (m)"] = (summary["hazardous_fragment_distance_m"], (hi - lo) / 2, 1.0)
    for b in summary["buildings"]:
        for name, mean, se in (("impacts", "expected_impacts", "impacts_std_error"),
                               ("penetrations", "expected_penetrations", "penetrations_std_error")):
            out[b["id"] + " " + name] = (b[mean], b[se], None)
    for k in ("building", "left_site"):
        o = summary["outcomes"][k]
        out["outcome " + k] = (o["fragments"], o["fragments_std_error"], None)
    return out


def time_to(mean, se, wall, absolute):
    target = absolute if absolute is not None else 0.05 * mean
    if mean <= 0 or se <= 0 or target <= 0:
        return None
    return wall * (se / target) ** 2


def main():
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cli", default=os.path.join(root, "build/cli/fragsim"))
    ap.add_argument("--scenario", default=os.path.join(root, "examples/demo/scenario.json"))
    ap.add_argument("--batches", type=int, default=10)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--seed", type=int, default=None)
    ap.add_argument("--cells", default="", help="elevation x azimuth [x speed] cells, e.g. 24x72x4")
    ap.add_argument("--defensive", type=float, default=None)
    a = ap.parse_args()
    with open(a.scenario) as f:
        scenario = json.load(f)
    with tempfile.TemporaryDirectory() as tmp:
        plain_dir, is_dir = os.path.join(tmp, "plain"), os.path.join(tmp, "is")
        os.makedirs(plain_dir)
        os.makedirs(is_dir)
        plain = run(a.cli, scenario, {"max_batches": a.batches}, a.threads, a.seed, plain_dir)
        di = {}
        if a.cells:
            parts = [int(x) for x in a.cells.split("x")]
            di.update(elevation_cells=parts[0], azimuth_cells=parts[1])
            if len(parts) > 2:
                di["speed_cells"] = parts[2]
        if a.defensive is not None:
            di["defensive_fraction"] = a.defensive
        imp = run(a.cli, scenario, {"max_batches": a.batches, "direction_importance": di},
                  a.threads, a.seed, is_dir)
    tp, ti = plain["timing"]["wall_s"], imp["timing"]["wall_s"]
    print(f"{a.batches} batches; plain: {plain['histories_done']} histories in {tp:.2f} s; "
          f"importance sampling: {imp['histories_done']} histories "
          f"({imp['pilot_histories']} pilot) in {ti:.2f} s; {a.threads} threads")
    print(f"{'figure':42s} {'plain mean ± se':>22s} {'IS mean ± se':>22s} {'z':>6s} "
          f"{'T5 plain s':>11s} {'T5 IS s':>9s} {'gain':>7s}")
    fp, fi = figures(plain), figures(imp)
    gains = []
    study = [0.0, 0.0]  # the slowest building figure or the HFD: when a study would be done
    for name in fp:
        (mp, sp, absolute), (mi, si, _) = fp[name], fi[name]
        t5p, t5i = time_to(mp, sp, tp, absolute), time_to(mi, si, ti, absolute)
        z = (mi - mp) / (sp * sp + si * si) ** 0.5 if sp > 0 or si > 0 else 0.0
        if name.startswith("HFD"):
            mp, mi = sp, si  # the figure is the half band itself
            z = float("nan")
        gain = t5p / t5i if t5p and t5i else None
        if not name.startswith("outcome") and t5p and t5i:
            study = [max(study[0], t5p), max(study[1], t5i)]
        if gain:
            gains.append(gain)
        fmt = lambda v: f"{v:11.1f}" if v is not None else f"{'-':>11s}"
        print(f"{name:42s} {mp:10.4g} ± {sp:<9.3g} {mi:10.4g} ± {si:<9.3g} {z:6.2f} "
              f"{fmt(t5p)} {fmt(t5i)[2:]} {(f'{gain:7.1f}' if gain else '      -')}")
    if study[1] > 0:
        print(f"slowest building figure or HFD: plain {study[0]:.1f} s, importance sampling "
              f"{study[1]:.1f} s: {study[0] / study[1]:.1f} x")
    if gains:
        gains.sort()
        print(f"gain in time to precision: median {gains[len(gains) // 2]:.1f}, "
              f"min {gains[0]:.1f}, max {gains[-1]:.1f} over {len(gains)} figures")
    return 0


if __name__ == "__main__":
    sys.exit(main())
