"""Shared code of run.py and calibrate.py: the Authume data, the site and scenarios, fragsim runs,
the statistics and the stop-point map (README.md in this folder says what and why).

Needs /usr/bin/python3 with numpy (Debian: python3-numpy) and `h5dump` (Debian: hdf5-tools) to
read results.h5; no other package. The data (richefeu/AuthumeQuarryRockfalls_Data-in-Brief) are
read from a local copy and never written into this repository: that repository has no licence.

Axes. The data use y as the vertical axis. The site is built with `"axes": "y_up"`, which maps a
file point (x, y, z) to the site point (x, -z, y) (x east, y north, z up in fragsim's terms); every
drop point, measured stop and Rockable position is mapped the same way (`to_site`).
"""

import json
import math
import os
import subprocess
import sys
import time

import numpy as np

PROFILES = ("P1", "P2")
ZONES = ("Blue", "Gray", "Red")  # the DTM's substratum zones (data README)
# Site material name of each zone.
ZONE_MATERIAL = {"Blue": "blue_vegetated", "Gray": "gray_hard", "Red": "red_rocky"}
ROCKABLE_SHAPES = ("SP1A", "SP2A", "SP2B", "SP3A")


def to_site(p):
    """File (x, y up, z) -> site (x, -z, y): the `y_up` mapping of `fragsim site import`."""
    p = np.asarray(p, dtype=float)
    return np.stack([p[..., 0], -p[..., 2], p[..., 1]], axis=-1)


# ----------------------------------------------------------------------------------------- data


def check_blind(profile, allow_p2):
    """The blind protocol: nothing of P2 is read unless the caller says the calibration is
    committed (run.py --profile P2 does; calibrate.py never)."""
    if profile == "P2" and not allow_p2:
        sys.exit("refusing to read P2 data: the P1 calibration must be committed first")


def read_endpoints(data, profile, allow_p2=False):
    """Measured blocks: site stop points (n x 3), mass (n), bounding box L1 >= L2 >= L3 (n x 3)."""
    check_blind(profile, allow_p2)
    a = np.loadtxt(os.path.join(data, "EXP_endpoints", f"Endpoints_{profile}.txt"), ndmin=2)
    return to_site(a[:, 0:3]), a[:, 3], a[:, 4:7]


def read_drop_points(data, profile):
    """The profile's four drop points (site coordinates). Inputs, not outcomes."""
    a = np.loadtxt(os.path.join(data, "Drop_conditions", f"positions_{profile}.xyz"), ndmin=2)
    return to_site(a[:, 0:3])


def read_rockable(data, profile, allow_p2=False):
    """Rockable's final positions: the last row of every SIM_Trajectories/<profile>/<shape>/
    <drop>/orientation_k.txt, with its speed and shape. Returns (site points, speeds, shapes)."""
    check_blind(profile, allow_p2)
    pts, speeds, shapes = [], [], []
    root = os.path.join(data, "SIM_Trajectories", profile)
    for shape in ROCKABLE_SHAPES:
        for drop in range(1, 5):
            d = os.path.join(root, shape, f"Drop_position_{drop}")
            if not os.path.isdir(d):
                continue
            for name in sorted(os.listdir(d)):
                last = None
                with open(os.path.join(d, name)) as f:
                    for line in f:
                        if line.strip():
                            last = line
                row = [float(v) for v in last.split()]
                pts.append(row[1:4])
                speeds.append(math.sqrt(row[4] ** 2 + row[5] ** 2 + row[6] ** 2))
                shapes.append(shape)
    return to_site(np.array(pts)), np.array(speeds), shapes


def read_stl(path):
    """Triangles (m x 3 x 3) of an ASCII STL, file axes."""
    v = []
    with open(path) as f:
        for line in f:
            s = line.split()
            if s and s[0] == "vertex":
                v.append([float(s[1]), float(s[2]), float(s[3])])
    return np.array(v).reshape(-1, 3, 3)


def read_dtm(data):
    """{zone: site triangles (m x 3 x 3)} of the three DTM zone files."""
    return {
        z: to_site(read_stl(os.path.join(data, "Geometries", "STL", f"DTM_{z}_zone.stl")))
        for z in ZONES
    }


def zone_at(dtm, pts):
    """Per plan point: the zone whose triangle (seen from above) holds it, the highest surface
    winning; None off the DTM's footprint. Used to say where a block stopped."""
    pts = np.asarray(pts, dtype=float).reshape(-1, 3)
    best_z = np.full(len(pts), -np.inf)
    zone = [None] * len(pts)
    for name, t in dtm.items():
        a, b, c = t[:, 0], t[:, 1], t[:, 2]
        d = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
        ok = np.abs(d) > 1e-12
        a, b, c, d = a[ok], b[ok], c[ok], d[ok]
        lo = np.minimum(np.minimum(a, b), c)
        hi = np.maximum(np.maximum(a, b), c)
        for k, p in enumerate(pts):
            m = (lo[:, 0] <= p[0]) & (p[0] <= hi[:, 0]) & (lo[:, 1] <= p[1]) & (p[1] <= hi[:, 1])
            for i in np.nonzero(m)[0]:
                l1 = ((b[i, 0] - p[0]) * (c[i, 1] - p[1]) - (b[i, 1] - p[1]) * (c[i, 0] - p[0])) / d[i]
                l2 = ((c[i, 0] - p[0]) * (a[i, 1] - p[1]) - (c[i, 1] - p[1]) * (a[i, 0] - p[0])) / d[i]
                l3 = 1.0 - l1 - l2
                if min(l1, l2, l3) >= -1e-9:
                    z = l1 * a[i, 2] + l2 * b[i, 2] + l3 * c[i, 2]
                    if z > best_z[k]:
                        best_z[k], zone[k] = z, name
    return zone


# ------------------------------------------------------------------------- site and scenarios


# The skirt: a flat rectangle this far below the DTM's lowest point, over the DTM's plan bounds and
# this much beyond. The TIN does not cover its bounding box (11,396 of 97,020 nodes at 0.5 m); when
# this was written, `fragsim site import` refused to resample such meshes to a grid, and the skirt
# is the surface under those nodes. The importer now drops the uncovered cells instead
# (docs/gis.md); the skirt is kept so that the committed calibration's site is reproduced bit for
# bit. A block that reaches the DTM's rim falls off it into this pit (rather than leaving the site)
# and is counted as not stopped on the DTM either way.
SKIRT_DROP_M = 10.0
SKIRT_MARGIN_M = 2.0
SKIRT_MATERIAL = "off_dtm"


def write_skirt(data, path):
    """An ASCII STL (file axes, y up) of the skirt: two facets."""
    v = np.concatenate([read_stl(os.path.join(data, "Geometries", "STL", f"DTM_{z}_zone.stl")).reshape(-1, 3) for z in ZONES])
    lo, hi = v.min(axis=0) - SKIRT_MARGIN_M, v.max(axis=0) + SKIRT_MARGIN_M
    y = v[:, 1].min() - SKIRT_DROP_M
    c = [(lo[0], y, lo[2]), (hi[0], y, lo[2]), (hi[0], y, hi[2]), (lo[0], y, hi[2])]
    with open(path, "w") as f:
        f.write("solid skirt\n")
        for tri in ((0, 2, 1), (0, 3, 2)):
            f.write("facet normal 0 1 0\nouter loop\n")
            for k in tri:
                f.write("vertex %.4f %.4f %.4f\n" % c[k])
            f.write("endloop\nendfacet\n")
        f.write("endsolid skirt\n")


def write_import(data, path, grid_spacing_m):
    """The `fragsim site import` file of the DTM: the three zone meshes, y up, each with its
    zone's material (placeholder values: every run sets its own, `set_materials`), and the skirt
    below them (written next to the import file)."""
    stl = os.path.join(os.path.abspath(data), "Geometries", "STL")
    skirt = os.path.join(os.path.dirname(os.path.abspath(path)), "skirt.stl")
    write_skirt(data, skirt)
    imp = {
        "schema": "fragsim.site_import/1",
        "description": "Authume quarry DTM (richefeu/AuthumeQuarryRockfalls_Data-in-Brief), "
        "three substratum zones over a skirt",
        "terrain": {
            "meshes": [
                {"path": os.path.join(stl, f"DTM_{z}_zone.stl"), "material": ZONE_MATERIAL[z]}
                for z in ZONES
            ]
            + [{"path": skirt, "material": SKIRT_MATERIAL}],
            "axes": "y_up",
            "weld_m": 1e-6,
            "grid_spacing_m": grid_spacing_m,
        },
        "materials": {
            **{
                ZONE_MATERIAL[z]: {"friction": 0.5, "restitution": 0.3, "rolling_resistance": 0.1}
                for z in ZONES
            },
            # Off the DTM: a block stops where it lands (no data about that ground).
            SKIRT_MATERIAL: {"friction": 1.0, "restitution": 0.0, "rolling_resistance": 1.0},
        },
    }
    with open(path, "w") as f:
        json.dump(imp, f, indent=1)


def import_site(fragsim, data, out, grid_spacing_m):
    """Runs `fragsim site import` once and returns the site document (cached in OUT)."""
    imp = os.path.join(out, "import.json")
    site_path = os.path.join(out, f"site_{grid_spacing_m:g}m.json")
    if not os.path.exists(site_path):
        write_import(data, imp, grid_spacing_m)
        subprocess.run([fragsim, "site", "import", imp, "--out", site_path], check=True)
    with open(site_path) as f:
        return json.load(f)


def material_names(site):
    """Every material name the terrain refers to (its own, per-triangle and zone lists)."""
    t = site["terrain"]
    names = {t["material"]}
    names.update(t.get("triangle_materials", {}).get("names", []))
    names.update(z["material"] for z in t.get("zones", []))
    return names


def set_materials(site, params):
    """A copy of SITE with the zone materials of PARAMS: {zone: material object or the name of a
    built-in ("hard", "soft")}. A built-in replaces the zone's material name wherever the terrain
    uses it, so the run gets exactly what a user gets without defining the material."""
    s = json.loads(json.dumps(site))
    rename = {}
    for zone, m in params.items():
        if zone.startswith("_"):
            continue
        name = ZONE_MATERIAL[zone]
        if isinstance(m, str):
            rename[name] = m
            s["materials"].pop(name, None)
        else:
            s["materials"][name] = {k: v for k, v in m.items() if not k.startswith("_")}
    t = s["terrain"]
    t["material"] = rename.get(t["material"], t["material"])
    if "triangle_materials" in t:
        t["triangle_materials"]["names"] = [rename.get(n, n) for n in t["triangle_materials"]["names"]]
    for z in t.get("zones", []):
        z["material"] = rename.get(z["material"], z["material"])
    used = material_names(s)
    s["materials"] = {k: v for k, v in s["materials"].items() if k in used}
    return s


def fragment_groups(drops, masses, boxes, samples, shape_fn=None):
    """One group per measured block and drop point: the block's mass and bounding box (a cuboid
    L1 x L2 x L3), its centre released at rest at the drop point in a uniformly random attitude.
    Each group stands for a quarter of the block (count 0.25), so every block weighs the same and
    is spread evenly over the four points (the data do not say which block fell from which)."""
    groups = []
    for b, (m, box) in enumerate(zip(masses, boxes)):
        for d, p in enumerate(drops):
            shape = shape_fn(b) if shape_fn else {"type": "cuboid", "dims_m": [float(x) for x in box]}
            groups.append(
                {
                    "name": f"block{b + 1:02d}_drop{d + 1}",
                    "count": 0.25,
                    "samples": samples,
                    "frame": {"origin_m": [float(x) for x in p]},
                    "shape": shape,
                    "mass_kg": float(m),
                    "speed_mps": 0,
                    "cd": 1.0,
                    "attitude": "random",
                }
            )
    return groups


def scenario(site, groups, seed=1, description=""):
    return {
        "schema": "fragsim.scenario/1",
        "description": description,
        "site": site,
        "fragment_groups": groups,
        "settings": {
            "seed": seed,
            "bounce": True,
            "record_fragments": True,
            # The harmless cut-off ends a history on the ground once its energy above the
            # lowest terrain point is below this: 1 J stops a 300 kg block within 8 cm/s of rest.
            "hazardous_ke_j": 1.0,
            "max_flight_time_s": 300,
        },
    }


# ------------------------------------------------------------------------------- fragsim runs


def h5_dataset(path, name):
    """A dataset of results.h5 as a numpy array, read with h5dump (hdf5-tools)."""
    tmp = path + "." + name.strip("/").replace("/", "_") + ".txt"
    subprocess.run(
        ["h5dump", "-y", "-w", "0", "-o", tmp, "-d", name, path],
        check=True,
        stdout=subprocess.DEVNULL,
    )
    with open(tmp) as f:
        vals = [float(v) for v in f.read().replace(",", " ").split()]
    os.remove(tmp)
    return np.array(vals)


def h5_outcome_names(path):
    """The /fragments/outcome attribute `names`."""
    r = subprocess.run(
        ["h5dump", "-a", "/fragments/outcome/names", path], check=True, capture_output=True, text=True
    )
    line = next(s for s in r.stdout.split("\n") if s.strip().startswith("(0)"))
    return line.split('"')[1].split(",")


def run_fragsim(fragsim, scen, out_dir, threads=2):
    """Writes SCEN, runs it, returns (per-history group index, end points n x 3, outcome names,
    summary.json, wall seconds of the command)."""
    os.makedirs(out_dir, exist_ok=True)
    sp = os.path.join(out_dir, "scenario.json")
    with open(sp, "w") as f:
        json.dump(scen, f)
    t0 = time.time()
    subprocess.run(
        [fragsim, "run", sp, "--out", out_dir, "--threads", str(threads), "--quiet"], check=True
    )
    wall = time.time() - t0
    h5 = os.path.join(out_dir, "results.h5")
    group = h5_dataset(h5, "/fragments/group").astype(int)
    end = h5_dataset(h5, "/fragments/end_position_m").reshape(-1, 3)
    names = h5_outcome_names(h5)
    outcome = [names[int(k)] for k in h5_dataset(h5, "/fragments/outcome")]
    with open(os.path.join(out_dir, "summary.json")) as f:
        summary = json.load(f)
    return group, end, outcome, summary, wall


# ------------------------------------------------------------------------------- statistics


def kolmogorov_q(lam):
    """Q_KS(lambda) = 2 sum_{k>=1} (-1)^(k-1) exp(-2 k^2 lambda^2), the Kolmogorov distribution's
    tail (Numerical Recipes, 3rd ed., 6.14)."""
    if lam < 0.2:
        return 1.0
    s, k = 0.0, 1
    while True:
        t = 2.0 * (-1) ** (k - 1) * math.exp(-2.0 * k * k * lam * lam)
        s += t
        if abs(t) < 1e-12 or k > 200:
            return max(0.0, min(1.0, s))
        k += 1


def ks_two_sample(a, b):
    """Two-sample Kolmogorov-Smirnov distance D and its asymptotic p-value, with the effective
    size n_e = n_a n_b / (n_a + n_b) and Stephens' correction
    lambda = (sqrt(n_e) + 0.12 + 0.11 / sqrt(n_e)) D (Numerical Recipes, 14.3.3)."""
    a, b = np.sort(np.asarray(a)), np.sort(np.asarray(b))
    x = np.concatenate([a, b])
    fa = np.searchsorted(a, x, side="right") / len(a)
    fb = np.searchsorted(b, x, side="right") / len(b)
    d = float(np.max(np.abs(fa - fb)))
    ne = len(a) * len(b) / (len(a) + len(b))
    lam = (math.sqrt(ne) + 0.12 + 0.11 / math.sqrt(ne)) * d
    return d, kolmogorov_q(lam)


def geometry(drops, measured):
    """The frame the statistics are read in: the drop points' centre and the unit direction from it
    to the measured stop points' mean (the mean path direction), plan view."""
    c = np.mean(drops[:, :2], axis=0)
    u = np.mean(measured[:, :2], axis=0) - c
    return c, u / np.linalg.norm(u)


def stop_stats(pts, c, u):
    """Run-out (horizontal distance from the drop points' centre) and lateral offset (signed
    distance from the mean path line) of plan points, every point weighing the same."""
    d = np.asarray(pts)[:, :2] - c
    runout = np.hypot(d[:, 0], d[:, 1])
    lateral = u[0] * d[:, 1] - u[1] * d[:, 0]
    return {
        "n": int(len(runout)),
        "runout_median_m": float(np.median(runout)),
        "runout_p90_m": float(np.percentile(runout, 90)),
        "runout_max_m": float(np.max(runout)),
        "runout_mean_m": float(np.mean(runout)),
        "lateral_mean_m": float(np.mean(lateral)),
        "lateral_std_m": float(np.std(lateral)),
        "lateral_abs_p90_m": float(np.percentile(np.abs(lateral), 90)),
    }, runout


def compare(sim_pts, meas_pts, c, u):
    """Statistics of a simulated set against the measured one: both sets' figures, the KS test on
    the run-out and the median error."""
    s, rs = stop_stats(sim_pts, c, u)
    m, rm = stop_stats(meas_pts, c, u)
    d, p = ks_two_sample(rs, rm)
    return {
        "sim": s,
        "measured": m,
        "ks_d": d,
        "ks_p": p,
        "median_rel_error": (s["runout_median_m"] - m["runout_median_m"]) / m["runout_median_m"],
    }


def objective(cmp):
    """The calibration's misfit: KS distance + |median error| / measured median (README)."""
    return cmp["ks_d"] + abs(cmp["median_rel_error"])


# ------------------------------------------------------------------------------- the SVG map


def svg_map(path, dtm, drops, measured, sim, rockable=None, title="", cell_m=2.0):
    """Plan view (x east right, y north up): the DTM's zones, the simulated stop density (cells
    of CELL_M, shaded by histories per cell), Rockable's stops (small diamonds), the measured stops
    (white dots) and the drop points (crosses). Written by hand: no plotting package."""
    allp = [measured[:, :2], drops[:, :2]]
    if len(sim):
        allp.append(sim[:, :2])
    if rockable is not None and len(rockable):
        allp.append(rockable[:, :2])
    allp = np.concatenate(allp)
    lo = np.percentile(allp, 0.5, axis=0) - 15.0
    hi = np.percentile(allp, 99.5, axis=0) + 15.0
    lo = np.minimum(lo, np.min(np.concatenate([measured[:, :2], drops[:, :2]]), axis=0) - 15)
    hi = np.maximum(hi, np.max(np.concatenate([measured[:, :2], drops[:, :2]]), axis=0) + 15)
    scale = 800.0 / max(hi - lo)
    w, h = (hi - lo) * scale

    def xy(p):
        return (p[0] - lo[0]) * scale, h - (p[1] - lo[1]) * scale

    colours = {"Blue": "#cfe3f5", "Gray": "#dddddd", "Red": "#f4cccc"}
    out = [
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{w:.0f}" height="{h + 80:.0f}" '
        f'viewBox="0 0 {w:.0f} {h + 80:.0f}" font-family="sans-serif" font-size="12">',
        f'<rect width="{w:.0f}" height="{h:.0f}" fill="white"/>',
    ]
    for zone, tris in dtm.items():
        out.append(f'<g fill="{colours[zone]}" stroke="{colours[zone]}" stroke-width="0.3">')
        for t in tris:
            if (t[:, 0] < lo[0]).all() or (t[:, 0] > hi[0]).all():
                continue
            if (t[:, 1] < lo[1]).all() or (t[:, 1] > hi[1]).all():
                continue
            pts = " ".join("%.1f,%.1f" % xy(p) for p in t)
            out.append(f'<polygon points="{pts}"/>')
        out.append("</g>")
    if len(sim):
        nx = int(math.ceil((hi[0] - lo[0]) / cell_m))
        ny = int(math.ceil((hi[1] - lo[1]) / cell_m))
        hist, _, _ = np.histogram2d(
            sim[:, 0], sim[:, 1], bins=[nx, ny], range=[[lo[0], lo[0] + nx * cell_m], [lo[1], lo[1] + ny * cell_m]]
        )
        top = hist.max()
        out.append('<g stroke="none">')
        for i, j in zip(*np.nonzero(hist)):
            a = 0.15 + 0.85 * math.sqrt(hist[i, j] / top)
            x0, y1 = xy((lo[0] + i * cell_m, lo[1] + j * cell_m))
            out.append(
                f'<rect x="{x0:.1f}" y="{y1 - cell_m * scale:.1f}" width="{cell_m * scale:.1f}" '
                f'height="{cell_m * scale:.1f}" fill="#c0392b" fill-opacity="{a:.2f}"/>'
            )
        out.append("</g>")
    if rockable is not None and len(rockable):
        out.append('<g fill="none" stroke="#1e7b34" stroke-width="0.8">')
        for p in rockable:
            x, y = xy(p)
            out.append(f'<path d="M{x:.1f},{y - 2.5:.1f} l2.5,2.5 l-2.5,2.5 l-2.5,-2.5 z"/>')
        out.append("</g>")
    out.append('<g fill="white" stroke="black" stroke-width="1.2">')
    for p in measured:
        x, y = xy(p)
        out.append(f'<circle cx="{x:.1f}" cy="{y:.1f}" r="3.2"/>')
    out.append("</g>")
    out.append('<g stroke="#1f4e9c" stroke-width="2">')
    for p in drops:
        x, y = xy(p)
        out.append(f'<path d="M{x - 5:.1f},{y:.1f} h10 M{x:.1f},{y - 5:.1f} v10"/>')
    out.append("</g>")
    # 10 m scale bar and the legend
    x0, y0 = 10, h + 20
    out.append(f'<path d="M{x0},{y0} h{10 * scale:.1f}" stroke="black" stroke-width="2"/>')
    out.append(f'<text x="{x0}" y="{y0 + 15}">10 m</text>')
    legend = [
        title,
        f"red cells: fragsim stops ({cell_m:g} m cells, shade ~ sqrt(count)); white dots: measured stops",
        "green diamonds: Rockable stops; blue crosses: drop points; north up",
        "zones: blue vegetated, grey hard (walls, platforms), pink rocky",
    ]
    for k, text in enumerate(legend):
        out.append(f'<text x="{x0 + 10 * scale + 20:.0f}" y="{y0 + 4 + 14 * k}">{text}</text>')
    out.append("</svg>")
    with open(path, "w") as f:
        f.write("\n".join(out))
