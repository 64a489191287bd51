#!/usr/bin/env python3
"""Paired comparison: are its standard errors honest, seed after seed? (docs/comparison.md)

Runs `fragsim compare` of examples/minimal against a variant with a 60 m x 1 m x 3 m concrete
wall 15 m out in front of the explosion (it changes B1's impacts and the HFD) for seeds
1..N, and prints, for the HFD difference and for B1's impacts difference, the spread of the
difference over the seeds (what a standard error should estimate) against the mean and median of
the standard errors the runs reported, and the unpaired spread for scale (the base HFD's spread
over seeds times sqrt 2).

  python3 bench/paired_calibration.py [--seeds 30] [--fragsim build/cli/fragsim]
"""
import argparse
import json
import pathlib
import statistics as st
import subprocess
import tempfile

ROOT = pathlib.Path(__file__).resolve().parent.parent


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=30)
    ap.add_argument("--fragsim", default=str(ROOT / "build/cli/fragsim"))
    a = ap.parse_args()
    base = json.loads((ROOT / "examples/minimal/scenario.json").read_text())
    base["settings"]["record_fragments"] = False
    base["settings"]["record_trajectories"] = False
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        t = pathlib.Path(tmp)
        for seed in range(1, a.seeds + 1):
            b = json.loads(json.dumps(base))
            b["settings"]["seed"] = seed
            v = json.loads(json.dumps(b))
            v["site"]["buildings"].append({
                "id": "W", "footprint_m": [[15, -30], [16, -30], [16, 30], [15, 30]],
                "height_m": 3, "wall": "concrete_wall", "roof": "metal_roof"})
            (t / "b.json").write_text(json.dumps(b))
            (t / "v.json").write_text(json.dumps(v))
            subprocess.run([a.fragsim, "compare", t / "b.json", t / "v.json", "--out", t / "o",
                            "--quiet"], check=True)
            c = json.loads((t / "o/compare.json").read_text())
            rows.append((c["hfd"], c["buildings"][0]["impacts"]))
    hfd = [h for h, _ in rows]
    imp = [i for _, i in rows]
    print(f"{a.seeds} seeds, examples/minimal with and without the wall")
    print("HFD difference (m): mean {:.1f}, spread over seeds {:.1f}; jackknife se mean {:.1f}, "
          "median {:.1f}; unpaired (base spread x sqrt 2) {:.1f}".format(
              st.mean(h["difference_m"] for h in hfd), st.stdev(h["difference_m"] for h in hfd),
              st.mean(h["paired_std_error_m"] for h in hfd),
              st.median(h["paired_std_error_m"] for h in hfd),
              st.stdev(h["base_m"] for h in hfd) * 2 ** 0.5))
    print("B1 impacts difference: mean {:.3f}, spread over seeds {:.3f}; paired se mean {:.3f}; "
          "unpaired se mean {:.3f}".format(
              st.mean(i["difference"] for i in imp), st.stdev(i["difference"] for i in imp),
              st.mean(i["paired_std_error"] for i in imp),
              st.mean(i["unpaired_std_error"] for i in imp)))


if __name__ == "__main__":
    main()
