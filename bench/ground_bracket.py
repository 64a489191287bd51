#!/usr/bin/env python3
"""One-at-a-time bracket of the fast-contact ground model (docs/physics.md, "Fast contact on soil",
F1-F6): the scenario with bounce on is run at the nominal constants and at each end of each
constant's documented range, all with the same seed (common random numbers), and the HFD, its band
and the building totals are printed as a tornado table (widest swing first).

  python3 bench/ground_bracket.py examples/demo/scenario.json [--fragsim build/cli/fragsim]
                                   [--samples-scale X] [--json OUT.json]

The terrain material must have a `fast_contact` object. Runs go to a temporary folder.
"""
import argparse
import copy
import json
import os
import subprocess
import sys
import tempfile

# The ranges of docs/physics.md ("The bracket"): no measurement at fragment speeds narrows them.
RANGES = {
    "switch_speed_mps": (20.0, 50.0),
    "critical_angle_coefficient_deg": (14.4, 21.6),
    "drag_to_lift_ratio": (0.5, 2.0),
    "roughness_deg": (0.0, 5.0),
    "exit_angle_ratio": (0.5, 2.0),
}
NOMINAL = {"switch_speed_mps": 30.0, "critical_angle_coefficient_deg": 18.0,
           "drag_to_lift_ratio": 1.0, "roughness_deg": 2.0, "exit_angle_ratio": 1.0}


def run(fragsim, scenario, scale, workdir, tag):
    path = os.path.join(workdir, tag + ".json")
    with open(path, "w") as f:
        json.dump(scenario, f)
    out = os.path.join(workdir, tag)
    cmd = [fragsim, "run", path, "--out", out, "--quiet"]
    if scale != 1.0:
        cmd += ["--samples-scale", str(scale)]
    subprocess.run(cmd, check=True)
    with open(os.path.join(out, "summary.json")) as f:
        s = json.load(f)
    return {
        "hfd_m": s["hazardous_fragment_distance_m"],
        "hfd_band_m": s["hazardous_fragment_distance_band_m"],
        "hfd_bound": s["hfd_bound"],
        "impacts": sum(b["expected_impacts"] for b in s["buildings"]),
        "penetrations": sum(b["expected_penetrations"] for b in s["buildings"]),
        "wall_s": s["timing"]["wall_s"],
    }


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("scenario")
    ap.add_argument("--fragsim", default="build/cli/fragsim")
    ap.add_argument("--samples-scale", type=float, default=1.0)
    ap.add_argument("--json")
    a = ap.parse_args()
    with open(a.scenario) as f:
        base = json.load(f)
    base["settings"]["bounce"] = True
    base["settings"]["record_trajectories"] = False
    terrain = base["site"]["terrain"]["material"]
    if "fast_contact" not in base["site"]["materials"].get(terrain, {}):
        sys.exit("the terrain material has no fast_contact object")
    fc = base["site"]["materials"][terrain]["fast_contact"]
    nominal = {k: fc.get(k, v) for k, v in NOMINAL.items()}
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        nom = run(a.fragsim, base, a.samples_scale, tmp, "nominal")
        for key, (lo, hi) in RANGES.items():
            ends = []
            for end, value in (("lo", lo), ("hi", hi)):
                sc = copy.deepcopy(base)
                sc["site"]["materials"][terrain]["fast_contact"][key] = value
                ends.append(run(a.fragsim, sc, a.samples_scale, tmp, key + "_" + end))
            rows.append({"constant": key, "nominal": nominal[key], "range": [lo, hi],
                         "low": ends[0], "high": ends[1]})
    rows.sort(key=lambda r: -abs(r["high"]["hfd_m"] - r["low"]["hfd_m"]))
    print("nominal: HFD %.1f m (band %.1f-%.1f, %s), building impacts %.2f, penetrations %.2f"
          % (nom["hfd_m"], nom["hfd_band_m"][0], nom["hfd_band_m"][1], nom["hfd_bound"],
             nom["impacts"], nom["penetrations"]))
    print("| constant (nominal) | low end | HFD at low, m | HFD at high, m | impacts low / high"
          " | penetrations low / high |")
    print("|---|---|---|---|---|---|")
    for r in rows:
        lo, hi = r["low"], r["high"]
        print("| `%s` (%g) | %g … %g | %.1f | %.1f | %.2f / %.2f | %.2f / %.2f |"
              % (r["constant"], r["nominal"], r["range"][0], r["range"][1], lo["hfd_m"],
                 hi["hfd_m"], lo["impacts"], hi["impacts"], lo["penetrations"],
                 hi["penetrations"]))
    if a.json:
        with open(a.json, "w") as f:
            json.dump({"nominal": nom, "rows": rows}, f, indent=1)


if __name__ == "__main__":
    main()
