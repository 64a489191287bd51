"""The client against a real fragsimd (started here on a free loopback port, killed at the end):
every route it wraps, its errors, and results equal to the CLI's bit for bit.

The scenario is examples/minimal (2,000 histories, 20,000 terrain triangles, seed 42; about
0.05 s of simulation).
"""

import importlib.util
import json
import os
import shutil
import struct
import tempfile
import unittest
import warnings
from pathlib import Path

import numpy as np

import fragsim
from tests.support import MINIMAL, TOKEN, Daemon, cli_run

daemon = None


def setUpModule():
    global daemon
    daemon = Daemon()
    unittest.addModuleCleanup(daemon.stop)  # runs even when a test or the setup fails
    daemon.start()


def minimal():
    return json.loads(MINIMAL.read_text())


def long_running(samples=50_000_000):
    """The minimal scenario with many histories (cancelled long before its end)."""
    s = minimal()
    s["fragment_groups"][0]["samples"] = samples
    s["settings"]["record_fragments"] = False
    return s


def flat(node, path="", out=None):
    """Leaves of a JSON document; floats by their bit pattern (0.0 and -0.0 differ)."""
    out = {} if out is None else out
    if isinstance(node, dict):
        out[path + "{}"] = sorted(node)
        for k, v in node.items():
            flat(v, f"{path}.{k}", out)
    elif isinstance(node, list):
        out[path + "[]"] = len(node)
        for i, v in enumerate(node):
            flat(v, f"{path}[{i}]", out)
    elif isinstance(node, float):
        out[path] = ("float", struct.pack("<d", node).hex())
    else:
        out[path] = (type(node).__name__, node)
    return out


class ClientTest(unittest.TestCase):
    """One done job on a registered site (the daemon's run) and the CLI's run of the same file."""

    @classmethod
    def setUpClass(cls):
        cls.tmp = Path(tempfile.mkdtemp(prefix="fragsim-pytest-"))
        cls.c = fragsim.Client(daemon.url, TOKEN)
        cls.site = cls.c.upload_site(MINIMAL)
        cls.progress = []
        job = cls.c.submit(MINIMAL, site_id=cls.site["site_id"])
        cls.job_id = job["job_id"]
        cls.submitted = job
        cls.final = cls.c.wait(cls.job_id, timeout=120, callback=cls.progress.append)
        cli_run(MINIMAL, cls.tmp / "cli")
        cls.h5 = cls.c.download_results(cls.job_id, cls.tmp / "daemon.h5")

    @classmethod
    def tearDownClass(cls):
        shutil.rmtree(cls.tmp, ignore_errors=True)

    # -- service --------------------------------------------------------------------------

    def test_health_contract_version_and_metrics(self):
        h = fragsim.Client(daemon.url, token="").health()  # no token needed
        self.assertEqual(h["status"], "ok")
        self.assertEqual(self.c.api_version(), fragsim.API_VERSION)
        self.assertIn("paths:", self.c.openapi())
        self.assertIn("fragsimd_jobs", self.c.metrics())
        me = self.c.whoami()
        self.assertEqual(me["role"], "admin")  # a token without a role (docs/operations.md)
        self.assertTrue(me["auth"])
        self.assertTrue(me["owner"].startswith("tok_"), me)

    # -- sites ----------------------------------------------------------------------------

    def test_sites(self):
        again = self.c.upload_site(minimal()["site"])  # a site dict; same content, same id
        self.assertEqual(again["site_id"], self.site["site_id"])
        self.assertEqual(self.site["building_ids"], ["B1"])
        self.assertEqual(self.site["terrain_triangles"], 20000)
        self.assertIn(self.site["site_id"], [s["site_id"] for s in self.c.sites()])
        self.assertEqual(self.c.site(self.site["site_id"]), self.c.site(self.site["site_id"]))
        scene = self.c.site_scene(self.site["site_id"])
        self.assertEqual(scene["terrain_triangles"].shape, (20000, 3))
        self.assertEqual(scene.header["building_ids"], ["B1"])

    def test_a_site_in_use_cannot_be_deleted_and_a_cancelled_job_has_no_results(self):
        s = long_running()
        s["site"]["terrain"]["plane"]["cell_m"] = 60  # another site
        site_id = self.c.upload_site(s)["site_id"]
        job = self.c.submit(s, site_id=site_id, priority=-5)
        with self.assertRaises(fragsim.Conflict) as cm:
            self.c.delete_site(site_id)
        self.assertEqual(cm.exception.status, 409)
        self.assertEqual(self.c.cancel(job["job_id"])["state"], "cancelled")
        with self.assertRaises(fragsim.Conflict):
            self.c.cancel(job["job_id"])
        with self.assertRaises(fragsim.NotReady):
            self.c.summary(job["job_id"])
        with self.assertRaises(fragsim.JobFailed) as failed:
            self.c.wait(job["job_id"], timeout=10)
        self.assertEqual(failed.exception.status["state"], "cancelled")
        self.assertEqual(self.c.wait(job["job_id"], raise_on_failure=False)["state"], "cancelled")
        self.c.delete_site(site_id)
        with self.assertRaises(fragsim.NotFound):
            self.c.site(site_id)
        # Only a failed job can be retried.
        with self.assertRaises(fragsim.Conflict):
            self.c.retry(job["job_id"])
        # Finished (cancelled), it can be purged; then it is unknown.
        purged = self.c.purge(job["job_id"])
        self.assertEqual(purged["job_id"], job["job_id"])
        self.assertTrue(purged["purged"])
        self.assertEqual(purged["state"], "cancelled")
        self.assertGreaterEqual(purged["bytes_freed"], 0)
        with self.assertRaises(fragsim.NotFound):
            self.c.job(job["job_id"])
        with self.assertRaises(fragsim.NotFound):
            self.c.purge(job["job_id"])

    # -- jobs -----------------------------------------------------------------------------

    def test_submit_wait_and_progress(self):
        self.assertEqual(self.submitted["state"], "queued")
        self.assertEqual(self.submitted["warnings"], [])
        self.assertEqual(self.final["state"], "done")
        self.assertEqual(self.progress[-1]["state"], "done")
        done = [p["histories_done"] or 0 for p in self.progress]
        self.assertEqual(done, sorted(done))
        self.assertEqual(done[-1], 2000)
        # following a finished job yields its status once
        self.assertEqual([s["state"] for s in self.c.follow(self.job_id)], ["done"])

    def test_following_a_running_job_shows_progress(self):
        job = self.c.submit(long_running(100_000))  # inline site: not registered
        self.assertIsNone(job["site_id"])
        seen = list(self.c.follow(job["job_id"], poll_s=0.05, timeout=120))
        self.assertEqual(seen[-1]["state"], "done")
        running = [s for s in seen if s["state"] == "running"]
        self.assertTrue(running, [s["state"] for s in seen])
        fractions = [s["progress"] for s in seen]
        self.assertEqual(fractions, sorted(fractions))
        self.assertEqual(seen[-1]["histories_done"], 100_000)

    def test_list_and_status(self):
        jobs = self.c.jobs()
        self.assertIn(self.job_id, [j["job_id"] for j in jobs])
        self.assertTrue(all(j["state"] == "done" for j in self.c.jobs(state="done")))
        self.assertEqual(len(self.c.jobs(limit=1)), 1)
        st = self.c.job(self.job_id)
        self.assertEqual((st["state"], st["site_id"]), ("done", self.site["site_id"]))
        self.assertEqual(self.c.status(self.job_id)["job_id"], self.job_id)

    def test_idempotent_submission(self):
        first = self.c.submit(MINIMAL, site_id=self.site["site_id"], idempotency_key="py-42")
        again = self.c.submit(MINIMAL, site_id=self.site["site_id"], idempotency_key="py-42")
        self.assertEqual(first["job_id"], again["job_id"])
        with self.assertRaises(fragsim.Conflict) as cm:
            self.c.submit(MINIMAL, site_id=self.site["site_id"], idempotency_key="py-42",
                          priority=3)
        self.assertEqual((cm.exception.code, cm.exception.field), ("conflict", "idempotency_key"))
        self.c.wait(first["job_id"], timeout=60)

    def test_run_uploads_the_site_and_returns_the_summary(self):
        summary = self.c.run(MINIMAL, upload_site=True, results=self.tmp / "run.h5", timeout=60)
        self.assertEqual(summary["hazardous_fragment_distance_m"],
                         self.c.summary(self.job_id)["hazardous_fragment_distance_m"])
        self.assertTrue((self.tmp / "run.h5").exists())

    # -- errors ---------------------------------------------------------------------------

    def test_an_invalid_scenario_raises_unprocessable_with_the_field_path(self):
        s = minimal()
        s["fragment_groups"][0]["mass_kg"]["sigma_ln"] = -1
        with self.assertRaises(fragsim.Unprocessable) as cm:
            self.c.submit(s)
        e = cm.exception
        self.assertEqual((e.status, e.code), (422, "invalid_input"))
        self.assertEqual(e.field, "fragment_groups[0].mass_kg.sigma_ln")
        self.assertTrue(e.message)
        with self.assertRaises(fragsim.Unprocessable) as cm:
            self.c.submit(MINIMAL, site_id="s_0123456789abcdef")
        self.assertEqual(cm.exception.field, "site_id")
        with self.assertRaises(fragsim.LimitExceeded) as cm:
            self.c.submit(long_running(200_000_000))
        self.assertEqual(cm.exception.field, "fragment_groups")
        site = minimal()["site"]
        site["terrain"]["plane"]["cell_m"] = -3
        with self.assertRaises(fragsim.Unprocessable) as cm:
            self.c.upload_site(site)
        self.assertEqual(cm.exception.field, "terrain.plane.cell_m")

    def test_other_errors(self):
        with self.assertRaises(fragsim.Unauthorized) as cm:
            fragsim.Client(daemon.url, "wrong-token").jobs()
        self.assertEqual((cm.exception.status, cm.exception.code), (401, "unauthorized"))
        with self.assertRaises(fragsim.NotFound):
            self.c.job("j_0123456789abcdef")
        with self.assertRaises(fragsim.NotFound):
            self.c.job("not-an-id")
        with self.assertRaises(fragsim.BadRequest) as cm:
            self.c.jobs(state="finished")
        self.assertEqual((cm.exception.code, cm.exception.field), ("bad_parameter", "state"))
        with self.assertRaises(fragsim.BadRequest) as cm:
            self.c.jobs(limit=0)
        self.assertEqual(cm.exception.field, "limit")

    # -- results --------------------------------------------------------------------------

    def test_summary_equals_the_cli_run(self):
        daemon_summary = self.c.summary(self.job_id)
        cli = json.loads((self.tmp / "cli" / "summary.json").read_text())
        for s in (daemon_summary, cli):
            s.pop("timing")
            # the SHA-256 of the scenario as read: the CLI read the file (with its site), the
            # daemon the job's body (site_id in place of the site)
            s["provenance"].pop("scenario_sha256")
        a, b = flat(daemon_summary), flat(cli)
        diff = {k: (a.get(k), b.get(k)) for k in set(a) | set(b) if a.get(k) != b.get(k)}
        self.assertEqual(diff, {})
        stored = json.loads(self.c.download_summary(self.job_id, self.tmp / "s.json").read_text())
        self.assertEqual(stored["seed"], 42)

    def test_results_h5_equals_the_cli_run_bit_for_bit(self):
        with fragsim.results.open(self.h5) as d, \
                fragsim.results.open(self.tmp / "cli" / "results.h5") as c:
            da, ca = d.datasets(), c.datasets()
            self.assertEqual(sorted(da), sorted(ca))
            self.assertGreater(len(da), 50)
            for name in da:
                self.assertEqual(da[name].dtype, ca[name].dtype, name)
                self.assertEqual(da[name].tobytes(), ca[name].tobytes(), name)
            # timing, the stored scenario's "threads", and the SHA-256 of the scenario as read
            varying = {"created_utc", "wall_s", "threads", "scenario_json", "summary_json",
                       "scenario_sha256"}
            self.assertEqual({k: v for k, v in d.attrs.items() if k not in varying},
                             {k: v for k, v in c.attrs.items() if k not in varying})
            self.assertEqual(d.hfd.distance_m, c.summary["hazardous_fragment_distance_m"])
            db, cb = d.buildings(), c.buildings()
            self.assertTrue(db.equals(cb))
            self.assertTrue(d.fragments().equals(c.fragments()))

    def test_buildings_and_ptn_routes_equal_results_h5(self):
        with fragsim.results.open(self.h5) as r:
            df = r.buildings()
            for b, row in zip(self.c.buildings(self.job_id), df.itertuples()):
                self.assertEqual(
                    (b["id"], b["expected_impacts"], b["impacts_std_error"],
                     b["expected_penetrations"], b["penetrations_std_error"]),
                    (row.id, row.expected_impacts, row.impacts_std_error,
                     row.expected_penetrations, row.penetrations_std_error))
            ptn = self.c.ptn(self.job_id)
            self.assertEqual(ptn["triangles"], len(r.triangles))
            self.assertEqual(ptn["threshold_per_m2"], r.hfd.threshold_per_m2)
            np.testing.assert_array_equal(ptn["density_per_m2"], r.density_per_m2)
            np.testing.assert_array_equal(ptn["std_error_per_m2"], r.std_error_per_m2)
            geo = self.c.download_ptn_geojson(self.job_id, self.tmp / "hazard.geojson",
                                              min_density_per_m2=r.hfd.threshold_per_m2)
            features = json.loads(geo.read_text())["features"]
            self.assertEqual(sorted(f["properties"]["triangle"] for f in features),
                             list(np.flatnonzero(r.hazardous)))
            scene = self.c.job_scene(self.job_id, max_trajectories=0)
            np.testing.assert_array_equal(scene["density_per_m2"],
                                          r.density_per_m2.astype(np.float32))
            np.testing.assert_array_equal(scene["terrain_triangles"], r.triangles)

    def test_plan_boundary(self):
        with fragsim.results.open(self.h5) as r:
            hfd = r.hfd.distance_m
        pb = self.c.plan_boundary(self.job_id)
        self.assertEqual(pb["job_id"], self.job_id)
        self.assertAlmostEqual(pb["exact_hfd_m"], hfd, places=6)
        self.assertGreaterEqual(pb["smoothed_hfd_m"], pb["exact_hfd_m"])
        self.assertEqual(len(pb["envelope"]["radius_m"]), 36)
        self.assertEqual(self.c.plan_boundary(self.job_id, smoothing_m=30.0)["smoothing_m"], 30.0)
        with self.assertRaises(fragsim.BadRequest) as cm:
            self.c.plan_boundary(self.job_id, smoothing_m=-1.0)
        self.assertEqual(cm.exception.field, "smoothing_m")

    def test_maps(self):
        listing = self.c.maps(self.job_id)
        names = {f["name"]: f["bytes"] for f in listing["files"]}
        self.assertIn("hazard.gpkg", names)
        self.assertIsNone(listing["crs"])  # the minimal site's CRS is "local": no GeoJSON
        path = self.c.download_map(self.job_id, "hazard.gpkg", self.tmp / "h.gpkg")
        self.assertEqual(path.stat().st_size, names["hazard.gpkg"])
        self.assertEqual(path.read_bytes()[:16], b"SQLite format 3\0")
        got = self.c.download_maps(self.job_id, self.tmp / "maps")
        self.assertEqual(sorted(p.name for p in got), sorted(names))
        self.assertEqual({p.name: p.stat().st_size for p in got}, names)
        with self.assertRaises(fragsim.NotFound):
            self.c.download_map(self.job_id, "nope.tif", self.tmp / "nope.tif")
        self.assertFalse((self.tmp / "nope.tif").exists())
        self.assertFalse((self.tmp / "nope.tif.part").exists())

    def test_hazardous_area_as_a_geodataframe(self):
        if importlib.util.find_spec("geopandas") is None:
            with self.assertRaisesRegex(ImportError, "geopandas"):
                self.c.hazardous_area(self.job_id)
            self.skipTest("geopandas not installed (optional extra 'gis'): the ImportError checked")
        gdf = self.c.hazardous_area(self.job_id).set_index("band")
        self.assertEqual(sorted(gdf.index), ["estimate", "lower_1se", "upper_1se"])
        with fragsim.results.open(self.h5) as r:
            exact = float(r.area_m2[r.hazardous].sum())
        # the minimal site is a flat plane: the plan area is the triangles' area (the site has
        # no CRS, so the layer's coordinates are local metres whatever CRS GDAL labels them)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)
            area = float(gdf.geometry.area["estimate"])
        self.assertAlmostEqual(area, exact, delta=1e-6 * exact)

    def test_paired_comparison(self):
        c = self.c
        base = c.submit(minimal())
        c.wait(base["job_id"], timeout=60)
        variant = minimal()
        variant["site"]["buildings"][0]["footprint_m"] = [[80, -10], [100, -10], [100, 10], [80, 10]]
        job = c.compare(base["job_id"], variant)
        self.assertEqual(job["histories_total"], 2 * base["histories_total"])
        c.wait(job["job_id"], timeout=60)
        cmp = c.comparison(job["job_id"])
        self.assertEqual(cmp["changed"], ["site.buildings"])
        impacts = cmp["buildings"][0]["impacts"]
        self.assertEqual(impacts["base"], c.summary(base["job_id"])["buildings"][0]["expected_impacts"])
        self.assertAlmostEqual(impacts["difference"], impacts["variant"] - impacts["base"], places=12)
        self.assertLessEqual(impacts["paired_std_error"], impacts["unpaired_std_error"])
        if importlib.util.find_spec("pandas"):
            table = c.comparison_buildings(job["job_id"])
            self.assertEqual(list(table.index), ["B1"])
            self.assertEqual(table.loc["B1", "impacts_difference"], impacts["difference"])
        with tempfile.TemporaryDirectory() as tmp:
            path = c.download_comparison_h5(job["job_id"], Path(tmp) / "c.h5")
            self.assertEqual(path.read_bytes()[:8], b"\x89HDF\r\n\x1a\n")
        with self.assertRaises(fragsim.NotFound):
            c.comparison(base["job_id"])
        bad = minimal()
        bad["settings"]["seed"] = 7
        with self.assertRaises(fragsim.Unprocessable) as e:
            c.compare(base["job_id"], bad)
        self.assertEqual(e.exception.field, "settings.seed")

    def test_report(self):
        html = self.c.report_html(self.job_id)
        self.assertIn("<html", html[:500].lower())
        us = self.c.report_html(self.job_id, self.tmp / "r-us.html", units="us")
        self.assertIn("ft", us.read_text())
        with self.assertRaises(fragsim.BadRequest) as cm:
            self.c.report_html(self.job_id, units="imperial")
        self.assertEqual(cm.exception.field, "units")
        # the daemon's chromium: $CHROMIUM, else /usr/bin/chromium (report/report_pdf.cpp)
        if os.access(os.environ.get("CHROMIUM") or "/usr/bin/chromium", os.X_OK):
            pdf = self.c.download_report_pdf(self.job_id, self.tmp / "r.pdf")
            self.assertEqual(pdf.read_bytes()[:5], b"%PDF-")
        else:
            with self.assertRaises(fragsim.ServiceUnavailable) as cm:
                self.c.download_report_pdf(self.job_id, self.tmp / "r.pdf")
            self.assertEqual(cm.exception.code, "pdf_unavailable")


if __name__ == "__main__":
    unittest.main()
