#!/usr/bin/env python3
"""Actual spread of the PTN density over replicate seeds, per sampling method.

time_to_precision.py extrapolates from one run's *reported* standard errors; this measures what
the errors are: each method runs the scenario (default: the demo) once per seed, and per ring of
triangles (centroid distance from the origin in [lo, hi), density >= half the threshold, pooled
over the methods) it prints the variance of each triangle's density across the seeds, averaged
over the ring, against the mean reported se^2 (the spread / se ratio: 1 when the errors are
honest), and the gain over the first method per history and in CPU time.
docs/precision.md, "Scrambled Sobol launch", reports its output.

    bench/replicate_spread.py [--cli build/cli/fragsim] [--scenario examples/demo/scenario.json]
                              [--seeds 16] [--seed0 7000] [--samples-scale 1.0] [--batches 10]
                              [--methods plain,importance,imp_sobol16,imp_sobol4]
                              [--rings 118-160,100-118,60-100]

Needs numpy (Debian python3-numpy) and h5dump (hdf5-tools). The demo at scale 1.0 with 10
batches: ~11 s of CPU per run.
"""
import argparse
import json
import os
import resource
import subprocess
import tempfile

import numpy as np

import time_to_precision  # bench/: the same results.h5 reader (h5dump)

# Settings per method: `precision` with the HFD ring as the never-met target, so that
# importance sampling aims at it and every run does exactly --batches batches.
def methods(batches):
    p = {"max_batches": batches, "ptn_rel_error_at_hfd": 1e-9}
    di = dict(p, direction_importance={})
    sobol = lambda r: {"method": "sobol", "replicates": r}
    return {
        "plain": {"precision": p},
        "strata": {"precision": p, "stratified_launch": {}},
        "importance": {"precision": di},
        "imp_strata": {"precision": di, "stratified_launch": {}},
        "sobol16": {"precision": p, "stratified_launch": sobol(16)},
        "sobol4": {"precision": p, "stratified_launch": sobol(4)},
        "imp_sobol16": {"precision": di, "stratified_launch": sobol(16)},
        "imp_sobol4": {"precision": di, "stratified_launch": sobol(4)},
        "imp_sobol2": {"precision": di, "stratified_launch": sobol(2)},
    }


def h5(path, dataset):
    return np.array(time_to_precision.h5(path, dataset))


def run(a, scenario, settings, seed, out):
    s = json.loads(json.dumps(scenario))
    s["settings"].update(settings)
    s["settings"].update(seed=seed, record_trajectories=False, record_fragments=False, threads=2)
    os.makedirs(out, exist_ok=True)
    path = os.path.join(out, "scenario.json")
    with open(path, "w") as f:
        json.dump(s, f)
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run([a.cli, "run", path, "--out", out, "--quiet", "--samples-scale",
                    str(a.samples_scale)], check=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    res = os.path.join(out, "results.h5")
    return h5(res, "/ptn/density_per_m2"), h5(res, "/ptn/std_error_per_m2"), cpu, res


def bias(dens, first, m, sel):
    """The ring's total density, mean over the seeds, against the first method's: their ratio
    and z = difference / combined standard error of the two means over the seeds (unbiased
    methods: |z| mostly below 2)."""
    a, b = dens[first][:, sel].sum(1), dens[m][:, sel].sum(1)
    se = np.sqrt(a.var(ddof=1) / len(a) + b.var(ddof=1) / len(b))
    return f"total {b.mean() / a.mean():.3f} x {first}'s, z {(b.mean() - a.mean()) / se:+.2f}"


def main():
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cli", default=os.path.join(root, "build/cli/fragsim"))
    ap.add_argument("--scenario", default=os.path.join(root, "examples/demo/scenario.json"))
    ap.add_argument("--seeds", type=int, default=16)
    ap.add_argument("--seed0", type=int, default=7000)
    ap.add_argument("--samples-scale", type=float, default=1.0)
    ap.add_argument("--batches", type=int, default=10)
    ap.add_argument("--methods", default="plain,importance,imp_sobol16,imp_sobol4")
    ap.add_argument("--rings", default="118-160,100-118,60-100", help="m from the origin")
    a = ap.parse_args()
    table = methods(a.batches)
    names = a.methods.split(",")
    if any(m not in table for m in names):
        ap.error("--methods: any of " + ", ".join(table))
    with open(a.scenario) as f:
        scenario = json.load(f)
    dens, ses, cpu = {}, {}, {}
    with tempfile.TemporaryDirectory() as tmp:
        for m in names:
            rows, srows, c = [], [], 0.0
            for k in range(a.seeds):
                d, s, t, res = run(a, scenario, table[m], a.seed0 + k, os.path.join(tmp, m))
                rows.append(d)
                srows.append(s)
                c += t
                if "centroid" not in locals():
                    v = h5(res, "/terrain/vertices_m").reshape(-1, 3)
                    tri = h5(res, "/terrain/triangles").astype(int).reshape(-1, 3)
                    origin = np.array(json.load(open(os.path.join(tmp, m, "summary.json")))
                                      ["hfd_origin_m"][:2])
                    centroid = v[tri].mean(axis=1)[:, :2] - origin
            dens[m], ses[m], cpu[m] = np.array(rows), np.array(srows), c / a.seeds
    dist = np.hypot(centroid[:, 0], centroid[:, 1])
    thr = scenario["settings"]["hfd_threshold_per_m2"]
    pooled = np.mean([dens[m].mean(0) for m in names], axis=0)
    print(f"{a.seeds} seeds from {a.seed0}, {a.batches} batches, samples x {a.samples_scale}; "
          "CPU s per run: " + ", ".join(f"{m} {cpu[m]:.2f}" for m in names))
    for ring in a.rings.split(","):
        lo, hi = (float(x) for x in ring.split("-"))
        sel = (dist >= lo) & (dist < hi) & (pooled >= 0.5 * thr)
        base = dens[names[0]][:, sel].var(0, ddof=1).mean()
        print(f"ring {lo:g}-{hi:g} m, {sel.sum()} triangles:")
        for m in names:
            var = dens[m][:, sel].var(0, ddof=1).mean()
            se2 = (ses[m][:, sel] ** 2).mean()
            print(f"  {m:12s} variance {var:.3e}  reported se^2 {se2:.3e}  spread/se "
                  f"{np.sqrt(var / se2):.2f}  gain per history {base / var:6.2f}  in CPU time "
                  f"{base * cpu[names[0]] / (var * cpu[m]):6.2f}  {bias(dens, names[0], m, sel)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
