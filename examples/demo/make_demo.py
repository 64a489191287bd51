#!/usr/bin/env python3
"""Generate examples/demo/scenario.json, the bundled fragsim demo site.

A synthetic 2 km x 2 km test range: sloping ground, a hill to the north-east, an earth berm, ten
buildings, and a tilted JATO-like rocket motor whose case breaks up into radial, axial-forward and
axial-rearward fragment groups (the situation of Gan & Chrostowski, DDESB 2010, Fig. 7).
Terrain, buildings and material thresholds are invented for demonstration; see README.md.

Usage:  python3 make_demo.py            # writes scenario.json next to this file, prints checks
        python3 make_demo.py --table    # also prints the building table used in README.md

Plain Python 3 standard library; deterministic (no random numbers): running it twice gives a
byte-identical file. The geometry checks at the end raise AssertionError when a change breaks them.

Coordinates: site frame, x = east, y = north, z = up, metres; the explosion is at (0, 0).
`site.origin` only places that frame on the map (made-up UTM zone 11N coordinates) and gives the
altitude of z = 0 for the atmosphere.
"""
import json
import math
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
OUT = os.path.join(HERE, "scenario.json")

# ---------------------------------------------------------------------------------------------
# Terrain: heightfield on a 10 m grid, 201 x 201 nodes, x and y from -1000 to 1000 m.
GRID_ORIGIN = (-1000.0, -1000.0)
SPACING = 10.0
NX = NY = 201

# Base plane through z = 0 at the explosion point, rising gently to the north-west
# (0.6 % to the north, 0.4 % to the west: about 0.7 % grade).
SLOPE_X, SLOPE_Y = -0.004, 0.006

# Hill: cos^2 bump, smooth (C1) and exactly zero outside its radius, so the ground is an exact plane
# everywhere else (the explosion point, most buildings).
HILL_CENTRE = (450.0, 420.0)
HILL_HEIGHT = 30.0
HILL_RADIUS = 250.0  # 500 m across at the foot

# Earth berm (traverse) south of the explosion, running east-west. Defined on grid nodes so the
# 10 m heightfield represents it exactly: crest 30 m long (x 0..30) x 10 m wide (y -60..-50) at
# 4.5 m above the base plane, sides falling to the toe over one grid cell (10 m run for 4.5 m rise,
# about 1:2.2): base 50 m x 30 m (x -10..40, y -70..-40). Cross-section: trapezoid.
BERM_HEIGHT = 4.5
BERM_X = (-10.0, 0.0, 30.0, 40.0)   # toe, crest start, crest end, toe
BERM_Y = (-70.0, -60.0, -50.0, -40.0)

EXPLOSION_XY = (0.0, 0.0)
MOTOR_HEIGHT = 1.5  # motor axis above ground at the explosion point


def base_plane(x, y):
    return SLOPE_X * x + SLOPE_Y * y


def hill(x, y):
    r = math.hypot(x - HILL_CENTRE[0], y - HILL_CENTRE[1])
    if r >= HILL_RADIUS:
        return 0.0
    return HILL_HEIGHT * math.cos(0.5 * math.pi * r / HILL_RADIUS) ** 2


def trapezoid(v, t0, c0, c1, t1):
    """1 on [c0, c1], 0 outside (t0, t1), linear in between."""
    if v <= t0 or v >= t1:
        return 0.0
    if v < c0:
        return (v - t0) / (c0 - t0)
    if v > c1:
        return (t1 - v) / (t1 - c1)
    return 1.0


def berm(x, y):
    return BERM_HEIGHT * trapezoid(x, *BERM_X) * trapezoid(y, *BERM_Y)


def node_elevation(i, j):
    x = GRID_ORIGIN[0] + i * SPACING
    y = GRID_ORIGIN[1] + j * SPACING
    return round(base_plane(x, y) + hill(x, y) + berm(x, y), 2)  # cm


ELEV = [[node_elevation(i, j) for i in range(NX)] for j in range(NY)]  # ELEV[j][i]


def terrain_height(x, y):
    """Height of the triangulated grid as fragsim meshes it: each cell split along its
    (i, j)-(i+1, j+1) diagonal (core/scene/terrain_builder.cpp)."""
    u = (x - GRID_ORIGIN[0]) / SPACING
    v = (y - GRID_ORIGIN[1]) / SPACING
    i = min(max(int(math.floor(u)), 0), NX - 2)
    j = min(max(int(math.floor(v)), 0), NY - 2)
    fu, fv = u - i, v - j
    z00, z10 = ELEV[j][i], ELEV[j][i + 1]
    z01, z11 = ELEV[j + 1][i], ELEV[j + 1][i + 1]
    if fu >= fv:  # lower-right triangle (i,j), (i+1,j), (i+1,j+1)
        return z00 + fu * (z10 - z00) + fv * (z11 - z10)
    return z00 + fv * (z01 - z00) + fu * (z11 - z01)  # (i,j), (i+1,j+1), (i,j+1)


# ---------------------------------------------------------------------------------------------
# Materials. Penetration thresholds are the kinetic energy of the normal velocity component per
# presented area (J/m^2). They are NOT from a test series: chosen for a plausible ordering
# (glass << wood < metal deck < corrugated steel < concrete roof < brick < reinforced concrete)
# and so that, in this demo, heavy low-angle fragments near the site get through brick and light
# roofs while reinforced concrete stops almost everything.
ILLUSTRATIVE = "illustrative value, not from a test series"


def restitution_table(e):
    return {"normal_speed_mps": [3, 30, 300], "e": e}


MATERIALS = {
    "soil": {"friction": 0.9, "restitution": 0.2,
             "fast_contact": {"bulk_density_kg_m3": 1700},
             "illustrative": True,
             "source": "friction 0.9 for soft ground as used by Gan & Chrostowski (DDESB 2010); "
                       "restitution illustrative; fast_contact (docs/physics.md F1-F6): the "
                       "nominal constants, Johnson & Reid (1975) critical grazing angle, bulk "
                       "density 1700 kg/m^3 a typical soil value; not calibrated at fragment "
                       "speeds (docs/validation.md), illustrative"},
    "rc_wall": {"friction": 0.5, "restitution": restitution_table([0.5, 0.3, 0.1]),
                "penetration": {"ke_per_area_j_per_m2": 8.0e6},
                "illustrative": True, "source": ILLUSTRATIVE},
    "brick_wall": {"friction": 0.5, "restitution": restitution_table([0.45, 0.25, 0.08]),
                   "penetration": {"ke_per_area_j_per_m2": 1.5e6},
                   "illustrative": True, "source": ILLUSTRATIVE},
    "corrugated_steel_wall": {"friction": 0.4, "restitution": 0.3,
                              "penetration": {"ke_per_area_j_per_m2": 2.0e5},
                              "illustrative": True, "source": ILLUSTRATIVE},
    "wood_frame_wall": {"friction": 0.6, "restitution": 0.25,
                        "penetration": {"ke_per_area_j_per_m2": 8.0e4},
                        "illustrative": True, "source": ILLUSTRATIVE},
    "glass_curtain_wall": {"friction": 0.3, "restitution": 0.1,
                           "penetration": {"ke_per_area_j_per_m2": 2.0e3},
                           "illustrative": True, "source": ILLUSTRATIVE},
    "concrete_roof": {"friction": 0.5, "restitution": restitution_table([0.5, 0.3, 0.1]),
                      "penetration": {"ke_per_area_j_per_m2": 6.0e5},
                      "illustrative": True, "source": ILLUSTRATIVE},
    "metal_deck_roof": {"friction": 0.4, "restitution": 0.3,
                        "penetration": {"ke_per_area_j_per_m2": 1.2e5},
                        "illustrative": True, "source": ILLUSTRATIVE},
    "wood_roof": {"friction": 0.6, "restitution": 0.25,
                  "penetration": {"ke_per_area_j_per_m2": 5.0e4},
                  "illustrative": True, "source": ILLUSTRATIVE},
}

# ---------------------------------------------------------------------------------------------
# Buildings (footprint form; base elevation omitted: fragsim takes the lowest terrain under the
# footprint). Rectangles are given by centre, size (along the rotated x and y) and rotation
# (degrees, counter-clockwise); coordinates rounded to 0.1 m.


def rect(cx, cy, w, d, rot_deg=0.0):
    c, s = math.cos(math.radians(rot_deg)), math.sin(math.radians(rot_deg))
    pts = []
    for px, py in ((-w / 2, -d / 2), (w / 2, -d / 2), (w / 2, d / 2), (-w / 2, d / 2)):  # CCW
        pts.append([round(cx + c * px - s * py, 1), round(cy + s * px + c * py, 1)])
    return pts


def polar(dist, bearing_deg):
    """Point at a distance and compass bearing (clockwise from north) from the explosion."""
    b = math.radians(bearing_deg)
    return EXPLOSION_XY[0] + dist * math.sin(b), EXPLOSION_XY[1] + dist * math.cos(b)


# (id, footprint, height, wall, roof, description for the README)
BUILDINGS = [
    ("B01_guard_hut", rect(*polar(90, 330), 4, 3), 3.0, "wood_frame_wall", "wood_roof",
     "guard hut in the north-north-west radial lobe"),
    ("B02_workshop_behind_berm", rect(*polar(140, 163), 16, 10), 5.0, "brick_wall",
     "metal_deck_roof", "workshop behind the berm"),
    ("B03_workshop_exposed", rect(*polar(140, 343), 16, 10), 5.0, "brick_wall",
     "metal_deck_roof", "same workshop, no berm (compare with B02)"),
    ("B04_store_behind_berm", rect(*polar(230, 172), 20, 12), 6.0, "rc_wall", "concrete_roof",
     "store behind the berm"),
    ("B05_maintenance_L", None, 8.0, "brick_wall", "concrete_roof",
     "L-shaped maintenance building (concave footprint)"),
    ("B06_hill_radar", rect(330, 300, 14, 10, 40), 6.0, "corrugated_steel_wall", "metal_deck_roof",
     "radar building on the hill's south-west slope"),
    ("B07_warehouse_downrange", rect(*polar(720, 72), 40, 20, 18), 10.0, "corrugated_steel_wall",
     "metal_deck_roof", "warehouse on the motor axis (downrange)"),
    ("B08_admin_uprange", rect(*polar(300, 247.5), 30, 14, -22.5), 12.0, "brick_wall",
     "concrete_roof", "administration block on the reverse axis (uprange)"),
    ("B09_tower", rect(*polar(600, 200), 10, 10), 15.0, "rc_wall", "concrete_roof",
     "control tower"),
    ("B10_visitor_pavilion", rect(*polar(800, 85), 18, 12, 30), 4.0, "glass_curtain_wall",
     "metal_deck_roof", "glass visitor pavilion on the flank of the forward lobe"),
]


def l_footprint():
    # 40 m x 30 m with a 20 m x 15 m notch at the north-east corner, ~330 m south of the site.
    cx, cy = polar(330, 190)
    x0, y0 = round(cx - 20, 1), round(cy - 15, 1)
    return [[x0, y0], [x0 + 40, y0], [x0 + 40, y0 + 15], [x0 + 20, y0 + 15], [x0 + 20, y0 + 30],
            [x0, y0 + 30]]


BUILDINGS = [(b[0], b[1] if b[1] is not None else l_footprint()) + b[2:] for b in BUILDINGS]
BUILDINGS = [(bid, [[round(x, 1), round(y, 1)] for x, y in fp], h, w, r, d)
             for bid, fp, h, w, r, d in BUILDINGS]

# ---------------------------------------------------------------------------------------------
# The rocket motor. Axis tilted TILT_DEG above the horizon, pointing east-north-east
# (compass bearing 67.5 deg). Each group's local z is the motor axis, so the radial band is
# "elevation near 0" and the axial cones are "elevation near +/-90" in the local frame.
#
# fragsim: site <- local rotation R = Rz(yaw) Ry(-pitch) Rx(roll); yaw from +x (east) toward +y
# (north); positive pitch raises local +x. R ez = Rz(yaw) (-sin(pitch), 0, cos(pitch)), which is
# the axis (cos(tilt) cos(az), cos(tilt) sin(az), sin(tilt)) when pitch = -(90 - tilt) and
# yaw = az = 90 - bearing (compass bearing -> mathematical azimuth).
TILT_DEG = 20.0
AXIS_BEARING_DEG = 67.5
PITCH_DEG = -(90.0 - TILT_DEG)
YAW_DEG = 90.0 - AXIS_BEARING_DEG
ROLL_DEG = 0.0  # the groups are symmetric about the axis; roll changes nothing


def frame_rotation(yaw, pitch, roll):
    """Rz(yaw) Ry(-pitch) Rx(roll) as in core/fragments/sampling.h (degrees)."""
    def rz(a):
        c, s = math.cos(a), math.sin(a)
        return [[c, -s, 0], [s, c, 0], [0, 0, 1]]

    def ry(a):
        c, s = math.cos(a), math.sin(a)
        return [[c, 0, s], [0, 1, 0], [-s, 0, c]]

    def rx(a):
        c, s = math.cos(a), math.sin(a)
        return [[1, 0, 0], [0, c, -s], [0, s, c]]

    def mul(a, b):
        return [[sum(a[i][k] * b[k][j] for k in range(3)) for j in range(3)] for i in range(3)]

    r = math.radians
    return mul(mul(rz(r(yaw)), ry(-r(pitch))), rx(r(roll)))


def apply(m, v):
    return [sum(m[i][k] * v[k] for k in range(3)) for i in range(3)]


def local_direction(elev_deg, azim_deg):
    e, a = math.radians(elev_deg), math.radians(azim_deg)
    return [math.cos(e) * math.cos(a), math.cos(e) * math.sin(a), math.sin(e)]


GROUND_AT_EXPLOSION = terrain_height(*EXPLOSION_XY)
FRAME = {"origin_m": [EXPLOSION_XY[0], EXPLOSION_XY[1],
                      round(GROUND_AT_EXPLOSION + MOTOR_HEIGHT, 2)],
         "yaw_deg": YAW_DEG, "pitch_deg": PITCH_DEG, "roll_deg": ROLL_DEG,
         "velocity_mps": [0, 0, 0]}

# Drag coefficient against Mach number for chunky closure fragments: illustrative shape only
# (subsonic ~0.85-1.0, transonic peak ~1.5, supersonic ~1.3), not a measured table.
CD_MACH_TABLE = {"mach": [0.0, 0.6, 0.8, 1.0, 1.2, 1.5, 2.0, 3.0],
                 "cd": [0.85, 0.9, 1.1, 1.5, 1.45, 1.35, 1.3, 1.3]}

FRAGMENT_GROUPS = [
    {
        # Cylindrical steel case: thin plates thrown normal to the axis (within +/-12 deg).
        "name": "motor case, radial",
        "count": 1200,
        "samples": 50000,
        "frame": FRAME,
        "shape": {"type": "cuboid", "density_kg_m3": 7850, "aspect": [1, 0.6, 0.1]},
        "mass_kg": {"dist": "lognormal", "median": 0.03, "sigma_ln": 0.9, "min": 0.005, "max": 2.5},
        "speed_mps": {"dist": "normal", "mean": 750, "sigma": 120, "min": 400, "max": 1100},
        "direction": {"elevation_deg": [-12, 12], "azimuth_deg": [-180, 180]},
        "cd": 1.2,
    },
    {
        # Head-end closure and igniter hardware: chunky pieces in a 20 deg cone along +axis.
        "name": "head closure, axial forward",
        "count": 200,
        "samples": 20000,
        "frame": FRAME,
        "shape": {"type": "cylinder", "density_kg_m3": 7850, "aspect": [1, 0.8]},
        "mass_kg": {"dist": "lognormal", "median": 0.1, "sigma_ln": 0.8, "min": 0.02, "max": 4.0},
        "speed_mps": {"dist": "normal", "mean": 450, "sigma": 90, "min": 200, "max": 750},
        "direction": {"elevation_deg": [70, 90], "azimuth_deg": [-180, 180]},
        "cd": CD_MACH_TABLE,
    },
    {
        # Nozzle and aft closure pieces: a 20 deg cone along -axis, i.e. 0-40 deg below the
        # horizon from 1.5 m up. Without bounce most end within ~20 m of the motor.
        "name": "nozzle and aft closure, axial rearward",
        "count": 120,
        "samples": 10000,
        "frame": FRAME,
        "shape": {"type": "cuboid", "density_kg_m3": 7850, "aspect": [1, 0.7, 0.25]},
        "mass_kg": {"dist": "uniform", "min": 0.05, "max": 0.6},
        "speed_mps": {"dist": "normal", "mean": 350, "sigma": 70, "min": 150, "max": 600},
        "direction": {"elevation_deg": [-90, -70], "azimuth_deg": [-180, 180]},
        "cd": 1.0,
    },
]

SETTINGS = {
    "seed": 20100713,
    "person_height_m": 1.8,
    "hazardous_ke_j": 79,
    "hfd_threshold_per_m2": 1 / 55.74,
    "max_flight_time_s": 120,
    "integrator": {"rtol": 1e-6, "sagitta_m": 0.05},
    "bounce": False,
    "threads": 0,
    "record_fragments": True,
    "record_trajectories": True,
}

DESCRIPTION = (
    "fragsim demo site (synthetic): a 2 km x 2 km range with gently sloping ground, a 30 m hill to "
    "the north-east, a 4.5 m earth berm 40-70 m south of the explosion, and ten buildings at "
    "90-800 m. A JATO-like solid rocket motor 1.5 m above ground, axis tilted 20 deg up and "
    "pointing east-north-east, breaks up into radial case fragments and axial-forward and "
    "axial-rearward closure fragments (cf. Gan & Chrostowski, DDESB 2010, Fig. 7). Terrain, "
    "buildings, fragment data, material restitution and penetration thresholds and the Cd(Mach) "
    "table are invented, illustrative values for demonstration only, not for safety decisions. "
    "Generated by examples/demo/make_demo.py."
)


def scenario():
    return {
        "schema": "fragsim.scenario/1",
        "description": DESCRIPTION,
        "site": {
            "origin": {"crs": "EPSG:32611", "easting_m": 452300, "northing_m": 3839800,
                       "elevation_m": 400},
            "terrain": {
                "grid": {"origin_m": list(GRID_ORIGIN), "spacing_m": SPACING, "nx": NX, "ny": NY,
                         "elevation_m": [z for row in ELEV for z in row]},
                "material": "soil",
            },
            "materials": MATERIALS,
            "buildings": [{"id": bid, "footprint_m": fp, "height_m": h, "wall": w, "roof": r}
                          for bid, fp, h, w, r, _ in BUILDINGS],
        },
        "atmosphere": {"model": "isa", "wind_mps": [0, 0, 0]},
        "gravity_mps2": 9.80665,
        "fragment_groups": FRAGMENT_GROUPS,
        "settings": SETTINGS,
    }


# ---------------------------------------------------------------------------------------------
# JSON output: indented, but small objects on one line, one building / material per line and the
# elevations as NY rows of NX numbers.


def number(v):
    if isinstance(v, bool) or not isinstance(v, float):
        return json.dumps(v)
    if v == int(v) and abs(v) < 1e4:
        return str(int(v))
    if abs(v) >= 1e4 or abs(v) < 1e-4:  # 8e6, 1.5e5, 1e-6
        mant, exp = f"{v:.12e}".split("e")
        return mant.rstrip("0").rstrip(".") + "e" + str(int(exp))
    return repr(v)


def compact(obj):
    if isinstance(obj, dict):
        return "{" + ", ".join(json.dumps(k) + ": " + compact(v) for k, v in obj.items()) + "}"
    if isinstance(obj, list):
        return "[" + ", ".join(compact(v) for v in obj) + "]"
    if isinstance(obj, (int, float)) and not isinstance(obj, bool):
        return number(obj)
    return json.dumps(obj, ensure_ascii=False)


def render(obj, path=(), indent=0):
    pad, inner = "  " * indent, "  " * (indent + 1)
    if path and path[-1] == "elevation_m":
        rows = [",".join(number(z) for z in obj[k:k + NX]) for k in range(0, len(obj), NX)]
        return "[\n" + ",\n".join(inner + r for r in rows) + "\n" + pad + "]"
    one_line = compact(obj)
    forced = len(path) >= 2 and path[-2] in ("materials", "buildings")
    if not isinstance(obj, (dict, list)) or forced or (len(one_line) <= 120 and len(path) >= 1):
        return one_line
    if isinstance(obj, dict):
        items = [inner + json.dumps(k) + ": " + render(v, path + (k,), indent + 1)
                 for k, v in obj.items()]
        return "{\n" + ",\n".join(items) + "\n" + pad + "}"
    items = [inner + render(v, path + (k,), indent + 1) for k, v in enumerate(obj)]
    return "[\n" + ",\n".join(items) + "\n" + pad + "]"


# ---------------------------------------------------------------------------------------------
# Checks


def cross(o, a, b):
    return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])


def segments_meet(p1, p2, q1, q2):
    d1, d2 = cross(q1, q2, p1), cross(q1, q2, p2)
    d3, d4 = cross(p1, p2, q1), cross(p1, p2, q2)
    if ((d1 > 0) != (d2 > 0)) and ((d3 > 0) != (d4 > 0)) and d1 and d2 and d3 and d4:
        return True

    def on(a, b, c):
        return (cross(a, b, c) == 0 and min(a[0], b[0]) <= c[0] <= max(a[0], b[0])
                and min(a[1], b[1]) <= c[1] <= max(a[1], b[1]))
    return on(q1, q2, p1) or on(q1, q2, p2) or on(p1, p2, q1) or on(p1, p2, q2)


def inside(poly, p):
    n, c = len(poly), False
    for k in range(n):
        a, b = poly[k], poly[(k + 1) % n]
        if (a[1] > p[1]) != (b[1] > p[1]):
            if p[0] < a[0] + (p[1] - a[1]) * (b[0] - a[0]) / (b[1] - a[1]):
                c = not c
    return c


def polygons_overlap(p, q):
    n, m = len(p), len(q)
    for i in range(n):
        for j in range(m):
            if segments_meet(p[i], p[(i + 1) % n], q[j], q[(j + 1) % m]):
                return True
    return inside(q, p[0]) or inside(p, q[0])


def point_segment_distance(p, a, b):
    ax, ay = b[0] - a[0], b[1] - a[1]
    t = max(0.0, min(1.0, ((p[0] - a[0]) * ax + (p[1] - a[1]) * ay) / (ax * ax + ay * ay)))
    return math.hypot(a[0] + t * ax - p[0], a[1] + t * ay - p[1])


def polygon_distance(p, q):
    if polygons_overlap(p, q):
        return 0.0
    d = float("inf")
    for poly, other in ((p, q), (q, p)):
        for v in poly:
            for k in range(len(other)):
                d = min(d, point_segment_distance(v, other[k], other[(k + 1) % len(other)]))
    return d


def area(poly):
    n = len(poly)
    return 0.5 * sum(poly[k][0] * poly[(k + 1) % n][1] - poly[(k + 1) % n][0] * poly[k][1]
                     for k in range(n))


def centroid(poly):
    a = area(poly)
    cx = cy = 0.0
    for k in range(len(poly)):
        x0, y0 = poly[k]
        x1, y1 = poly[(k + 1) % len(poly)]
        f = x0 * y1 - x1 * y0
        cx += (x0 + x1) * f
        cy += (y0 + y1) * f
    return cx / (6 * a), cy / (6 * a)


def base_elevation(fp):
    """Lowest terrain height under the footprint: vertices, edge samples and interior nodes."""
    zs = []
    for k in range(len(fp)):
        a, b = fp[k], fp[(k + 1) % len(fp)]
        for s in range(21):
            t = s / 20
            zs.append(terrain_height(a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])))
    xs, ys = [p[0] for p in fp], [p[1] for p in fp]
    for i in range(NX):
        x = GRID_ORIGIN[0] + i * SPACING
        if min(xs) <= x <= max(xs):
            for j in range(NY):
                y = GRID_ORIGIN[1] + j * SPACING
                if min(ys) <= y <= max(ys) and inside(fp, (x, y)):
                    zs.append(ELEV[j][i])
    return min(zs)


def line_blocked(p0, p1, step=0.25):
    """True when the straight segment p0 -> p1 passes below the terrain somewhere between
    (end points excluded)."""
    length = math.dist(p0, p1)
    n = max(2, int(length / step))
    for s in range(1, n - 1):
        t = s / n
        x, y, z = (p0[k] + t * (p1[k] - p0[k]) for k in range(3))
        if z < terrain_height(x, y):
            return True
    return False


def facade_cover(fp, height, eye):
    """Highest h such that every sampled point of the walls up to h (above the building base) is
    hidden from `eye` by terrain; 0 when some point at ground level is visible. Samples every
    ~1 m along each wall that faces the eye, at 0.5 m height steps."""
    zb = base_elevation(fp)
    ccw = area(fp) > 0
    hidden_to = None
    levels = [0.25 + 0.5 * k for k in range(int(height / 0.5))] + [height]
    for lvl in levels:
        for k in range(len(fp)):
            a, b = fp[k], fp[(k + 1) % len(fp)]
            # outward normal; skip walls facing away from the eye (not visible anyway)
            nx_, ny_ = (b[1] - a[1], a[0] - b[0]) if ccw else (a[1] - b[1], b[0] - a[0])
            mx, my = (a[0] + b[0]) / 2, (a[1] + b[1]) / 2
            if nx_ * (eye[0] - mx) + ny_ * (eye[1] - my) <= 0:
                continue
            n = max(1, int(math.dist(a, b)))
            for s in range(n + 1):
                t = s / n
                p = (a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]), zb + lvl)
                if not line_blocked(eye, p):
                    return hidden_to if hidden_to is not None else 0.0
        hidden_to = lvl
    return hidden_to


def bearing(dx, dy):
    return math.degrees(math.atan2(dx, dy)) % 360.0


def check_and_report(show_table):
    ex, ey = EXPLOSION_XY
    eye = (ex, ey, FRAME["origin_m"][2])

    # Frame: local z must come out along the intended motor axis.
    R = frame_rotation(YAW_DEG, PITCH_DEG, ROLL_DEG)
    az = math.radians(90.0 - AXIS_BEARING_DEG)
    t = math.radians(TILT_DEG)
    want = [math.cos(t) * math.cos(az), math.cos(t) * math.sin(az), math.sin(t)]
    got = apply(R, [0, 0, 1])
    err = max(abs(g - w) for g, w in zip(got, want))
    print(f"frame: yaw {YAW_DEG} deg, pitch {PITCH_DEG} deg, roll {ROLL_DEG} deg")
    print(f"  R*ez = ({got[0]:.6f}, {got[1]:.6f}, {got[2]:.6f})  intended axis = "
          f"({want[0]:.6f}, {want[1]:.6f}, {want[2]:.6f})  max error {err:.1e}")
    assert err < 1e-12
    for name, (el, azl) in (("forward cone centre (el 90)", (90, 0)),
                            ("rearward cone centre (el -90)", (-90, 0))):
        d = apply(R, local_direction(el, azl))
        print(f"  {name}: bearing {bearing(d[0], d[1]):6.2f} deg, elevation "
              f"{math.degrees(math.asin(d[2])):6.2f} deg")
    # Radial band: every local elevation-0 direction is perpendicular to the axis; report the
    # horizontal ones (bearings where the band skims the ground).
    worst = 0.0
    for k in range(360):
        d = apply(R, local_direction(0.0, k))
        worst = max(worst, abs(sum(a * b for a, b in zip(d, want))))
    assert worst < 1e-12
    print(f"  radial band (local el 0) perpendicular to the axis: max |cos| {worst:.1e}; "
          f"horizontal at bearings {AXIS_BEARING_DEG + 90:.1f} and "
          f"{AXIS_BEARING_DEG - 90 + 360:.1f}")

    # Terrain
    zmin = min(min(r) for r in ELEV)
    zmax = max(max(r) for r in ELEV)
    print(f"terrain: z {zmin:.2f} .. {zmax:.2f} m (site frame; +400 m ASL); ground at the "
          f"explosion {GROUND_AT_EXPLOSION:.2f} m, motor at z = {eye[2]:.2f} m")
    crest = [ELEV[j][i] - base_plane(GRID_ORIGIN[0] + i * SPACING, GRID_ORIGIN[1] + j * SPACING)
             for j in range(NY) for i in range(NX)
             if BERM_X[1] <= GRID_ORIGIN[0] + i * SPACING <= BERM_X[2]
             and BERM_Y[1] <= GRID_ORIGIN[1] + j * SPACING <= BERM_Y[2]]
    print(f"berm: {len(crest)} crest nodes at {min(crest):.2f}..{max(crest):.2f} m above the base "
          f"plane; toe rectangle x {BERM_X[0]}..{BERM_X[3]}, y {BERM_Y[0]}..{BERM_Y[3]}")
    berm_poly = [[BERM_X[0], BERM_Y[0]], [BERM_X[3], BERM_Y[0]], [BERM_X[3], BERM_Y[3]],
                 [BERM_X[0], BERM_Y[3]]]
    assert not inside(berm_poly, EXPLOSION_XY), "explosion inside the berm"
    d_berm = min(point_segment_distance(EXPLOSION_XY, berm_poly[k], berm_poly[(k + 1) % 4])
                 for k in range(4))
    print(f"  explosion to berm toe: {d_berm:.1f} m")
    assert abs(hill(*EXPLOSION_XY)) == 0 and berm(*EXPLOSION_XY) == 0

    # Buildings
    fps = [(b[0], b[1]) for b in BUILDINGS]
    assert len(set(b for b, _ in fps)) == len(fps), "duplicate building id"
    for k, (bid, fp) in enumerate(fps):
        assert all(-1000 < x < 1000 and -1000 < y < 1000 for x, y in fp), bid + " off the grid"
        assert not inside(fp, EXPLOSION_XY), bid + " contains the explosion"
        gap = polygon_distance(fp, berm_poly)
        assert gap > 5.0, f"{bid} touches the berm ({gap:.1f} m)"
        for bid2, fp2 in fps[k + 1:]:
            gap = polygon_distance(fp, fp2)
            assert gap > 5.0, f"{bid} and {bid2} overlap or touch ({gap:.1f} m)"
    rows = []
    for bid, fp, h, wall, roof, desc in BUILDINGS:
        cx, cy = centroid(fp)
        dist = math.hypot(cx - ex, cy - ey)
        near = min(point_segment_distance(EXPLOSION_XY, fp[k], fp[(k + 1) % len(fp)])
                   for k in range(len(fp)))
        brg = bearing(cx - ex, cy - ey)
        rel = (brg - AXIS_BEARING_DEG + 180) % 360 - 180
        zb = base_elevation(fp)
        zmax_fp = max(terrain_height(x, y) for x, y in fp)
        cover = facade_cover(fp, h, eye)
        if cover >= h:  # how far above the roof the berm's line-of-sight shadow reaches
            cover = facade_cover(fp, 40.0, eye)
        xs, ys = [p[0] for p in fp], [p[1] for p in fp]
        edges = [math.dist(fp[k], fp[(k + 1) % len(fp)]) for k in range(len(fp))]
        if len(fp) == 4:
            size = f"{edges[0]:.0f} x {edges[1]:.0f}"
        else:
            size = f"L {max(xs) - min(xs):.0f} x {max(ys) - min(ys):.0f}"
        rows.append((bid, desc, size, abs(area(fp)), h, wall, roof, dist, near, brg, rel, zb,
                     zmax_fp - zb, cover))
    print("buildings (distance to centroid / nearest wall, compass bearing, bearing relative to "
          "the motor axis, base z, ground rise across footprint, facade hidden up to):")
    for (bid, desc, size, a, h, wall, roof, dist, near, brg, rel, zb, rise, cover) in rows:
        print(f"  {bid:26s} {size:>9s} m h {h:4.1f}  {dist:5.0f}/{near:5.0f} m  brg {brg:5.1f}  "
              f"rel {rel:+6.1f}  base z {zb:6.2f} rise {rise:4.1f}  hidden to {cover:4.2f} m")
    shielded = [r[0] for r in rows if r[13] >= r[4]]
    print("fully shielded from direct line of sight (all walls, full height):", ", ".join(shielded))
    assert {"B02_workshop_behind_berm", "B04_store_behind_berm"} <= set(shielded), shielded
    exposed = [r[0] for r in rows if r[13] == 0.0]
    assert "B03_workshop_exposed" in exposed
    hill_b = [r for r in rows if r[0] == "B06_hill_radar"][0]
    assert hill_b[12] > 1.0, "B06 should sit on the slope"

    total = sum(g["samples"] for g in FRAGMENT_GROUPS)
    print(f"fragment groups: {len(FRAGMENT_GROUPS)}, samples {total}, real fragments "
          f"{sum(g['count'] for g in FRAGMENT_GROUPS)}")

    if show_table:
        print()
        print("| id | building | footprint (m) | height (m) | wall | roof | distance (m) | "
              "bearing (deg) | from motor axis (deg) | shielded by berm |")
        print("|---|---|---|---|---|---|---|---|---|---|")
        for (bid, desc, size, a, h, wall, roof, dist, near, brg, rel, zb, rise, cover) in rows:
            sh = (f"yes: hidden up to {cover:.1f} m above its base" if cover >= h else
                  f"lower {cover:.1f} m" if cover > 0 else "no")
            print(f"| `{bid}` | {desc} | {size} | {h:g} | `{wall}` | `{roof}` | {dist:.0f} "
                  f"({near:.0f}) | {brg:.0f} | {rel:+.0f} | {sh} |")


def main():
    text = render(scenario()) + "\n"
    json.loads(text)  # well-formed
    with open(OUT, "w", encoding="utf-8", newline="\n") as f:
        f.write(text)
    print(f"wrote {OUT} ({len(text.encode('utf-8'))} bytes)")
    check_and_report("--table" in sys.argv[1:])


if __name__ == "__main__":
    main()
