#!/usr/bin/python3
"""fragsim against the Authume quarry rockfall tests (README.md in this folder).

  run.py --data DIR --fragsim PATH [--profile P1|P2] [--params FILE] [--samples N] [--out DIR]
         [--shape cuboid|polyhedron] [--grid-spacing M] [--seed S] [--threads T] [--label L]

Builds the site with `fragsim site import`, writes the profile's scenario (one fragment group per
measured block and drop point), runs it, and compares the stop points with the measured ones and
with Rockable's. Writes OUT/<profile>_<label>/: scenario.json, summary.json, results.h5,
report.json, map.svg. Needs /usr/bin/python3 with numpy (python3-numpy) and h5dump (hdf5-tools).

Blind protocol: --profile P2 runs only once calibration.json is committed in this folder.
"""

import argparse
import json
import os
import subprocess
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.dont_write_bytecode = True  # no __pycache__ in the source tree
sys.path.insert(0, HERE)
import authume_lib as lib  # noqa: E402


def calibration_committed():
    """True when calibration.json is in git's HEAD and unchanged in the work tree."""
    path = os.path.join(HERE, "calibration.json")
    if not os.path.exists(path):
        return False
    log = subprocess.run(
        ["git", "-C", HERE, "log", "-1", "--format=%H", "--", "calibration.json"],
        capture_output=True,
        text=True,
    )
    diff = subprocess.run(["git", "-C", HERE, "diff", "--quiet", "HEAD", "--", "calibration.json"])
    return bool(log.stdout.strip()) and diff.returncode == 0


def load_params(path):
    """{zone: material object or built-in name}; a file may hold them under "materials"."""
    with open(path) as f:
        p = json.load(f)
    p = p.get("materials", p)
    missing = [z for z in lib.ZONES if z not in p]
    if missing:
        sys.exit(f"{path}: no material for zone(s) {', '.join(missing)}")
    return {z: p[z] for z in lib.ZONES}


def polyhedron_shape(fragsim, data, out):
    """`fragsim shape import` of the four scanned boulders (SP1A, SP2A, SP2B, SP3A), each with a
    density so that its convex hull is scaled to each block's measured mass. The data do not say
    which measured block had which shape (only that P2's block 37 is SP3A): block b gets scan b mod 4.
    Returns a function block index -> shape."""
    shapes = []
    for name in lib.ROCKABLE_SHAPES:
        stl = os.path.join(data, "Geometries", "STL", f"{name}.stl")
        r = subprocess.run(
            [fragsim, "shape", "import", stl, "--axes", "y_up"], check=True, capture_output=True, text=True
        )
        s = json.loads(r.stdout)
        s.pop("dims_m", None)
        s["density_kg_m3"] = 2650.0  # a typical limestone (illustrative: rock type and density not given)
        shapes.append(s)
    with open(os.path.join(out, "polyhedra.json"), "w") as f:
        json.dump(shapes, f)
    return lambda b: shapes[b % len(shapes)]


def run_profile(args, site, params, label, shape_fn=None):
    """One fragsim run of ARGS.profile with PARAMS; returns the report dictionary."""
    allow_p2 = args.profile == "P2"
    drops = lib.read_drop_points(args.data, args.profile)
    meas, masses, boxes = lib.read_endpoints(args.data, args.profile, allow_p2)
    groups = lib.fragment_groups(drops, masses, boxes, args.samples, shape_fn)
    scen = lib.scenario(
        lib.set_materials(site, params),
        groups,
        seed=args.seed,
        description=f"Authume {args.profile} ({label}): {len(masses)} measured blocks x 4 drop points",
    )
    out = os.path.join(args.out, f"{args.profile}_{label}")
    group, end, outcome, summary, wall = lib.run_fragsim(args.fragsim, scen, out, args.threads)
    return report(args, drops, meas, group, end, outcome, summary, wall, out, params, label)


def report(args, drops, meas, group, end, outcome, summary, wall, out, params, label):
    dtm = lib.read_dtm(args.data)
    c, u = lib.geometry(drops, meas)
    left = np.array([o == "left_site" for o in outcome])
    stopped = np.array([o in ("ground", "harmless") for o in outcome])
    zones = lib.zone_at(dtm, end)
    on_dtm = np.array([z is not None for z in zones]) & ~left
    rep = {
        "profile": args.profile,
        "label": label,
        "params": params,
        "samples_per_group": args.samples,
        "groups": int(group.max() + 1),
        "histories": int(len(group)),
        "outcomes": {o: int(sum(1 for x in outcome if x == o)) for o in sorted(set(outcome))},
        "share_on_dtm": float(on_dtm.mean()),
        "share_stopped": float(stopped.mean()),
        "stops_by_zone": {z: int(sum(1 for x in zones if x == z)) for z in lib.ZONES},
        "wall_s_command": wall,
        "wall_s_run": summary["timing"]["wall_s"],
        "ms_per_block": 1e3 * summary["timing"]["wall_s"] / len(group),
        "threads": summary["timing"]["threads"],
        "drop_centre_m": c.tolist(),
        "path_direction": u.tolist(),
        # Every history's end point; those that left the site end where they left (a lower bound
        # of their run-out).
        "all": lib.compare(end, meas, c, u),
        "on_dtm": lib.compare(end[on_dtm], meas, c, u) if on_dtm.sum() > 1 else None,
    }
    meas_zones = lib.zone_at(dtm, meas)
    rep["measured_stops_by_zone"] = {z: int(sum(1 for x in meas_zones if x == z)) for z in lib.ZONES}
    rock = None
    if not args.no_rockable:
        rock, speeds, shapes = lib.read_rockable(args.data, args.profile, args.profile == "P2")
        rz = lib.zone_at(dtm, rock)
        rep["rockable"] = {
            "trajectories": int(len(rock)),
            "share_on_dtm": float(np.mean([z is not None for z in rz])),
            "share_final_speed_below_0.1_mps": float(np.mean(speeds < 0.1)),
            "all": lib.compare(rock, meas, c, u),
            "by_shape": {
                s: lib.compare(rock[[k for k, x in enumerate(shapes) if x == s]], meas, c, u)["sim"]
                for s in lib.ROCKABLE_SHAPES
            },
        }
    lib.svg_map(
        os.path.join(out, "map.svg"),
        dtm,
        drops,
        meas,
        end[on_dtm],
        rock,
        title=f"Authume {args.profile}, fragsim {label}",
    )
    with open(os.path.join(out, "report.json"), "w") as f:
        json.dump(rep, f, indent=1)
    return rep


def print_report(rep):
    a = rep["all"]
    m, s = a["measured"], a["sim"]
    print(f"== {rep['profile']} {rep['label']}: {rep['histories']} histories ({rep['groups']} groups x {rep['samples_per_group']})")
    print(f"   outcomes {rep['outcomes']}; on the DTM {100 * rep['share_on_dtm']:.1f} %; stops by zone {rep['stops_by_zone']}")
    print("   run-out (m)       median    p90    max  | lateral mean  std  |lat| p90")
    row = "   {:<15} {:7.1f} {:6.1f} {:6.1f}  | {:8.1f} {:6.1f} {:6.1f}"

    def line(name, x):
        print(row.format(name, x["runout_median_m"], x["runout_p90_m"], x["runout_max_m"], x["lateral_mean_m"], x["lateral_std_m"], x["lateral_abs_p90_m"]))

    line(f"measured n={m['n']}", m)
    line(f"fragsim n={s['n']}", s)
    print(f"   KS D {a['ks_d']:.3f} p {a['ks_p']:.3g} (n_meas {m['n']}, n_sim {s['n']}); median error {100 * a['median_rel_error']:+.1f} %; objective {lib.objective(a):.3f}")
    if "rockable" in rep:
        r = rep["rockable"]
        line(f"Rockable n={r['all']['sim']['n']}", r["all"]["sim"])
        print(f"   Rockable KS D {r['all']['ks_d']:.3f} p {r['all']['ks_p']:.3g}; median error {100 * r['all']['median_rel_error']:+.1f} %; on the DTM {100 * r['share_on_dtm']:.1f} %")
    print(f"   time: run {rep['wall_s_run']:.2f} s on {rep['threads']} threads, {rep['ms_per_block']:.2f} ms per block (wall / histories); command {rep['wall_s_command']:.1f} s")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", required=True, help="local copy of AuthumeQuarryRockfalls_Data-in-Brief")
    ap.add_argument("--fragsim", required=True, help="the fragsim CLI")
    ap.add_argument("--profile", choices=lib.PROFILES, default="P1")
    ap.add_argument("--params", help="zone materials (default: calibration.json, else start_params.json)")
    ap.add_argument("--label", help="name of the run's folder (default: the params file's name)")
    ap.add_argument("--samples", type=int, default=25, help="histories per block and drop point")
    ap.add_argument("--out", default="/tmp/authume")
    ap.add_argument("--shape", choices=("cuboid", "polyhedron"), default="cuboid")
    ap.add_argument("--grid-spacing", type=float, default=0.5, help="DTM resampling, m")
    ap.add_argument("--site", help="an imported site document to use instead of importing")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--no-rockable", action="store_true")
    args = ap.parse_args()
    if args.profile == "P2" and not calibration_committed():
        sys.exit("--profile P2: calibration.json is not committed (blind protocol: README.md)")
    if not args.params:
        cal = os.path.join(HERE, "calibration.json")
        args.params = cal if os.path.exists(cal) else os.path.join(HERE, "start_params.json")
    label = args.label or os.path.splitext(os.path.basename(args.params))[0]
    if args.shape == "polyhedron":
        label += "_polyhedron"
    os.makedirs(args.out, exist_ok=True)
    if args.site:
        with open(args.site) as f:
            site = json.load(f)
    else:
        site = lib.import_site(args.fragsim, args.data, args.out, args.grid_spacing)
    shape_fn = polyhedron_shape(args.fragsim, args.data, args.out) if args.shape == "polyhedron" else None
    t0 = time.time()
    rep = run_profile(args, site, load_params(args.params), label, shape_fn)
    print_report(rep)
    print(f"   written: {os.path.join(args.out, args.profile + '_' + label)} ({time.time() - t0:.1f} s)")


if __name__ == "__main__":
    main()
