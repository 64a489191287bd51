#!/usr/bin/env python3
"""Time to precision: plain Monte Carlo against stratified and importance sampling.

Runs a scenario (default: the demo) with settings.precision and no targets, so that every run
does exactly --batches batches of the groups' samples, once per method:
  plain        independent histories;
  stratified   settings.stratified_launch (2 histories per stratum of launch cells);
  importance   settings.precision.direction_importance (its pilot batch included in its time);
  both         importance sampling with stratified launch cells;
  sobol        scrambled Sobol nets (settings.stratified_launch.method "sobol");
  importance_sobol  importance sampling with Sobol nets.
For every figure with a nonzero mean it prints the time each run would need for a 5 %
relative standard error, extrapolated as T5 = T * (se / (0.05 * mean))^2 (se ~ 1/sqrt(n)), T the
run's CPU time (--clock wall: its wall time, which other jobs on the machine inflate), and
the gain T5(plain) / T5(method), i.e. the ratio of the figures of merit 1/(se^2 T). Figures: the
HFD half band (target 1 m instead of 5 %), each building's expected impacts and penetrations,
the PTN density at several distances (the median T5 over the terrain triangles whose centroid is
within [d, 1.1 d) of the HFD origin and whose density is nonzero in every run; read from
results.h5 with h5dump, Debian's hdf5-tools) and over the triangles that decide the HFD (plain
density within [0.5, 2] x the threshold, centroid at least 0.9 x the plain HFD out: the HFD's
precision is theirs; the half band is a step function of them, too noisy to extrapolate, see
docs/benchmarks.md §8), the building and left_site outcome counts. It also
prints, per method, z = (mean - plain mean) / combined se for every figure, the time until
the slowest building figure (nonzero in every run) reaches 5 %, and until that and the density
deciding the HFD both do (a study that names both kinds of target).
docs/benchmarks.md, "Time to precision".

    bench/time_to_precision.py [--cli build/cli/fragsim] [--scenario examples/demo/scenario.json]
                               [--batches 10] [--threads 2] [--seed N] [--cells 24x72[x1[x4]]]
                               [--defensive 0.3] [--methods plain,stratified,importance,both]
                               [--distances 50,100,150,200] [--focus all|buildings|hfd|both]
                               [--clock cpu|wall] [--replicates R]
"""
import argparse
import json
import math
import os
import re
import resource
import subprocess
import sys
import tempfile


def run(cli, scenario, settings, threads, seed, out):
    s = json.loads(json.dumps(scenario))
    s["settings"].update(settings)
    s["settings"]["record_fragments"] = False
    s["settings"]["threads"] = threads
    if seed is not None:
        s["settings"]["seed"] = seed
    os.makedirs(out, exist_ok=True)
    path = os.path.join(out, "scenario.json")
    with open(path, "w") as f:
        json.dump(s, f)
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run([cli, "run", path, "--out", out, "--quiet"], check=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    with open(os.path.join(out, "summary.json")) as f:
        summary = json.load(f)
    # CPU time of the run (all threads): unlike the wall time it does not grow when other jobs
    # share the machine's cores.
    summary["timing"]["cpu_s"] = (after.ru_utime - before.ru_utime) + (after.ru_stime -
                                                                        before.ru_stime)
    return summary


CLOCK = "cpu_s"  # --clock: the time each figure's T5 is computed from


def cost(summary):
    return summary["timing"][CLOCK]


def h5(path, dataset):
    """The values of a dataset of results.h5, flattened, through h5dump."""
    text = subprocess.run(["h5dump", "-y", "-w", "0", "-m", "%.17g", "-d", dataset, path],
                          check=True, capture_output=True, text=True).stdout
    body = text[text.index("DATA {") + 6:text.rindex("}", 0, text.rindex("}"))]
    return [float(v) for v in re.split(r"[,\s]+", body.strip().rstrip("}").strip()) if v]


def ring_triangles(out, origin, distances):
    """Per distance d: the triangles whose centroid lies within [d, 1.1 d) of the origin."""
    path = os.path.join(out, "results.h5")
    v = h5(path, "/terrain/vertices_m")
    t = [int(x) for x in h5(path, "/terrain/triangles")]
    rings = {d: [] for d in distances}
    for k in range(len(t) // 3):
        cx = sum(v[3 * t[3 * k + i]] for i in range(3)) / 3 - origin[0]
        cy = sum(v[3 * t[3 * k + i] + 1] for i in range(3)) / 3 - origin[1]
        r = math.hypot(cx, cy)
        for d in distances:
            if d <= r < 1.1 * d:
                rings[d].append(k)
    return rings


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


def hfd_triangles(out, origin, density, threshold, hfd_m):
    """The triangles that decide the HFD: plain density within [0.5, 2] x the threshold and
    centroid at least 0.9 x plain HFD from the origin."""
    path = os.path.join(out, "results.h5")
    v = h5(path, "/terrain/vertices_m")
    t = [int(x) for x in h5(path, "/terrain/triangles")]
    use = []
    for k in range(len(t) // 3):
        if not 0.5 * threshold <= density[k] <= 2.0 * threshold:
            continue
        cx = sum(v[3 * t[3 * k + i]] for i in range(3)) / 3 - origin[0]
        cy = sum(v[3 * t[3 * k + i] + 1] for i in range(3)) / 3 - origin[1]
        if math.hypot(cx, cy) >= 0.9 * hfd_m:
            use.append(k)
    return use


def ptn_times(runs, rings):
    """Per distance: per method the median T5 over the ring's triangles nonzero in every run;
    and the same over the triangles that decide the HFD (hfd_triangles of the plain run)."""
    density = {m: h5(os.path.join(d, "results.h5"), "/ptn/density_per_m2")
               for m, (_, d) in runs.items()}
    se = {m: h5(os.path.join(d, "results.h5"), "/ptn/std_error_per_m2")
          for m, (_, d) in runs.items()}
    plain, plain_out = runs["plain"]
    rings = dict(rings)
    rings["HFD"] = hfd_triangles(plain_out, plain["hfd_origin_m"], density["plain"],
                                 plain["hfd_threshold_per_m2"],
                                 plain["hazardous_fragment_distance_m"])
    out = {}
    for dist, tris in rings.items():
        use = [k for k in tris if all(density[m][k] > 0 and se[m][k] > 0 for m in runs)]
        if not use:
            continue
        times = {}
        for m, (s, _) in runs.items():
            wall = cost(s)
            t5 = sorted(time_to(density[m][k], se[m][k], wall, None) for k in use)
            times[m] = t5[len(t5) // 2]
        if dist == "HFD":
            out[f"PTN density deciding the HFD ({len(use)} triangles)"] = times
        else:
            out[f"PTN density at {dist:g} m ({len(use)} triangles)"] = times
    return out


# --focus: the figures importance sampling learns for, named as targets that are never met (so
# every run still does exactly --batches batches): all (no target), the buildings, or the HFD
# (the density near it, ptn_rel_error_at_hfd), or both kinds (a study that needs both names both).
FOCUS = {"all": {}, "buildings": {"building_rel_error": 1e-9},
         "hfd": {"ptn_rel_error_at_hfd": 1e-9},
         "both": {"building_rel_error": 1e-9, "ptn_rel_error_at_hfd": 1e-9}}


def precision(a, **extra):
    return dict({"max_batches": a.batches}, **FOCUS[a.focus], **extra)


METHODS = {
    "plain": lambda a, di: {"precision": precision(a)},
    "stratified": lambda a, di: {"precision": precision(a),
                                 "stratified_launch": {"histories_per_stratum": 2}},
    "importance": lambda a, di: {"precision": precision(a, direction_importance=di)},
    "both": lambda a, di: {"precision": precision(a, direction_importance=di),
                           "stratified_launch": {"histories_per_stratum": 2}},
    "sobol": lambda a, di: {"precision": precision(a), "stratified_launch": SOBOL(a)},
    "importance_sobol": lambda a, di: {"precision": precision(a, direction_importance=di),
                                       "stratified_launch": SOBOL(a)},
}


# Column headers are 10 characters wide: names that would read alike there.
SHORT = {"importance_sobol": "imp_sobol"}


def SOBOL(a):
    return dict({"method": "sobol"}, **({"replicates": a.replicates} if a.replicates else {}))


def main():
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cli", default=os.path.join(root, "build/cli/fragsim"))
    ap.add_argument("--scenario", default=os.path.join(root, "examples/demo/scenario.json"))
    ap.add_argument("--batches", type=int, default=10)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--seed", type=int, default=None)
    ap.add_argument("--cells", default="",
                    help="elevation x azimuth [x speed [x mass]] cells, e.g. 24x72x1x4")
    ap.add_argument("--defensive", type=float, default=None)
    ap.add_argument("--methods", default="plain,stratified,importance,both")
    ap.add_argument("--replicates", type=int, default=0,
                    help="sobol methods: nets per group and batch (default: the scenario's)")
    ap.add_argument("--distances", default="50,100,150,200", help="PTN rings, m")
    ap.add_argument("--focus", default="all", choices=list(FOCUS),
                    help="the figures importance sampling aims at (targets never met)")
    ap.add_argument("--clock", default="cpu", choices=["cpu", "wall"],
                    help="T5 from each run's CPU time (default: robust to other jobs on the "
                    "machine) or its wall time")
    a = ap.parse_args()
    global CLOCK
    CLOCK = a.clock + "_s"
    methods = a.methods.split(",")
    if methods[0] != "plain" or any(m not in METHODS for m in methods):
        ap.error("--methods: plain first, then any of " + ", ".join(list(METHODS)[1:]))
    with open(a.scenario) as f:
        scenario = json.load(f)
    di = {}
    if a.cells:
        parts = [int(x) for x in a.cells.split("x")]
        di.update(elevation_cells=parts[0], azimuth_cells=parts[1])
        if len(parts) > 2:
            di["speed_cells"] = parts[2]
        if len(parts) > 3:
            di["mass_cells"] = parts[3]
    if a.defensive is not None:
        di["defensive_fraction"] = a.defensive
    with tempfile.TemporaryDirectory() as tmp:
        runs = {}
        for m in methods:
            out = os.path.join(tmp, m)
            runs[m] = (run(a.cli, scenario, METHODS[m](a, di), a.threads, a.seed, out), out)
        plain = runs["plain"][0]
        rings = ring_triangles(runs["plain"][1], plain["hfd_origin_m"],
                               [float(x) for x in a.distances.split(",")])
        ptn = ptn_times(runs, rings)
    report(a, methods, runs, ptn)
    return 0


def report(a, methods, runs, ptn):
    print(f"{a.batches} batches, {a.threads} threads; " + "; ".join(
        f"{m}: {s['histories_done']} histories ({s['pilot_histories']} pilot) in "
        f"{s['timing']['wall_s']:.2f} s wall, {s['timing']['cpu_s']:.2f} s CPU"
        for m, (s, _) in runs.items()) + f"; T5 from the {CLOCK[:-2]} time")
    figs = {m: figures(s) for m, (s, _) in runs.items()}
    rest = methods[1:]
    print(f"{'figure':44s} {'plain mean ± se':>22s} {'T5 plain s':>10s} " +
          " ".join(f"{SHORT.get(m, m)[:10] + ' gain':>15s} {'z':>5s}" for m in rest))
    gains = {m: [] for m in rest}
    study = {m: 0.0 for m in methods}  # the slowest building figure
    for name, (mp, sp, absolute) in figs["plain"].items():
        t5 = {m: time_to(figs[m][name][0], figs[m][name][1], cost(runs[m][0]), absolute)
              for m in methods}
        if all(t5.values()) and name.startswith("B"):
            for m in methods:
                study[m] = max(study[m], t5[m])
        if not t5["plain"]:
            continue
        shown = sp if name.startswith("HFD") else mp
        line = f"{name:44s} {shown:10.4g} ± {sp:<9.3g} {t5['plain']:10.1f} "
        for m in rest:
            mm, sm, _ = figs[m][name]
            z = (mm - mp) / math.hypot(sp, sm) if not name.startswith("HFD") else float("nan")
            g = t5["plain"] / t5[m] if t5[m] else None
            if g:
                gains[m].append(g)
            line += f"{(f'{g:15.1f}' if g else '              -')} {z:5.2f} "
        print(line)
    for name, times in ptn.items():
        line = f"{name:44s} {'':22s} {times['plain']:10.1f} "
        for m in rest:
            g = times["plain"] / times[m]
            gains[m].append(g)
            line += f"{g:15.1f} {'':5s} "
        print(line)
    print("HFD and half band (indicative: one draw of a step function, not a standard error): " +
          ", ".join(f"{m} {figs[m]['HFD half band (m)'][0]:.1f} m ± {figs[m]['HFD half band (m)'][1]:.2f}"
                    for m in methods))
    print("slowest building figure (when a study with building targets is done): " +
          ", ".join(f"{m} {study[m]:.1f} s" for m in methods) + "; gains " +
          ", ".join(f"{m} {study['plain'] / study[m]:.1f} x" for m in rest if study[m] > 0))
    deciding = [k for k in ptn if k.startswith("PTN density deciding the HFD")]
    if deciding and all(study[m] > 0 for m in methods):
        both = {m: max(study[m], ptn[deciding[0]][m]) for m in methods}
        print("slowest of the building figures and the density deciding the HFD (when a study "
              "with both kinds of targets is done): " +
              ", ".join(f"{m} {both[m]:.1f} s" for m in methods) + "; gains " +
              ", ".join(f"{m} {both['plain'] / both[m]:.1f} x" for m in rest))
    for m in rest:
        g = sorted(gains[m])
        if g:
            print(f"{m}: gain in time to precision median {g[len(g) // 2]:.1f}, min {g[0]:.1f}, "
                  f"max {g[-1]:.1f} over {len(g)} figures")


if __name__ == "__main__":
    sys.exit(main())
