#!/usr/bin/env python3
"""Generate the Fletcher & Bowen (1968) block-drop scenarios used to validate fragsim's bounce,
slide and roll model (docs/validation.md).

The test (as summarised by Gan & Chrostowski, DDESB 2010, and docs/validation.md):
concrete-filled building blocks, 55.0-56.5 lb, 7.5 x 7.7 x 15.5 in, dropped from a truck bed
2.6 ft high moving at 10-60 mph onto a graded airstrip; the paper simulates 15-100 ft/s
horizontal release speeds in random orientation on its hard and soft surfaces.

Each scenario: one group of 500 blocks, released with the truck's speed (frame velocity, no
explosion-induced speed), random orientation (fragsim samples a uniform attitude per history),
no spin, onto a flat plane of the built-in "hard" or "soft" ground material. The centre of mass
starts 2.6 ft + 3.75 in above the ground: the truck bed height plus half the block's smallest
dimension (the block rests on its largest face on the bed). Travel distance = horizontal distance
from the release point to where the block comes to rest.

Usage: python3 make_scenarios.py   (writes hard-SPEEDfps.json and soft-SPEEDfps.json here)
Plain Python 3, deterministic.
"""
import json
import os

HERE = os.path.dirname(os.path.abspath(__file__))
FT, IN, LB = 0.3048, 0.0254, 0.45359237
SPEEDS_FPS = [15, 30, 45, 60, 75, 88, 100]


def scenario(surface, speed_fps):
    v = speed_fps * FT
    return {
        "schema": "fragsim.scenario/1",
        "description": ("Fletcher & Bowen (1968) block drop, %d ft/s, %s surface "
                        "(fragsim bounce validation, docs/validation.md)" % (speed_fps, surface)),
        "site": {
            "terrain": {"plane": {"elevation_m": 0.0, "extent_m": [-50.0, -100.0, 250.0, 100.0],
                                  "cell_m": 10.0},
                        "material": surface},
            "materials": {},
        },
        "atmosphere": {"model": "isa"},
        "fragment_groups": [{
            "name": "concrete-filled blocks",
            "count": 500,
            "samples": 500,
            "frame": {"origin_m": [0.0, 0.0, round(2.6 * FT + 3.75 * IN, 6)],
                      "velocity_mps": [round(v, 6), 0.0, 0.0]},
            "shape": {"type": "cuboid", "dims_m": [round(7.5 * IN, 6), round(7.7 * IN, 6),
                                                   round(15.5 * IN, 6)]},
            "mass_kg": {"dist": "uniform", "min": round(55.0 * LB, 6), "max": round(56.5 * LB, 6)},
            "speed_mps": 0.0,
            "cd": 1.05,
        }],
        "settings": {
            "seed": 1968,
            "bounce": True,
            # Keep every block tracked to rest (a block is far below 79 J only at the very end,
            # and the PTN tally is not what this validation looks at).
            "hazardous_ke_j": 1e-6,
            "record_fragments": True,
        },
    }


def main():
    for surface in ("hard", "soft"):
        for s in SPEEDS_FPS:
            path = os.path.join(HERE, "%s-%03dfps.json" % (surface, s))
            with open(path, "w") as f:
                json.dump(scenario(surface, s), f, indent=2)
                f.write("\n")
    print("wrote %d scenarios" % (2 * len(SPEEDS_FPS)))


if __name__ == "__main__":
    main()
