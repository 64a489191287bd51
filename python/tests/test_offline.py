"""What needs no daemon: error mapping, Retry-After handling (against a stub server), the
results reader's refusals, the scene parser."""

import http.server
import json
import os
import shutil
import struct
import tempfile
import threading
import time
import unittest
from pathlib import Path
from typing import Dict, List, Optional, Tuple
from unittest import mock

import numpy as np

import fragsim
from fragsim import errors
from tests.support import MINIMAL, cli_run


class ErrorMappingTest(unittest.TestCase):
    def test_status_and_code_choose_the_class(self):
        body = json.dumps({"code": "invalid_input", "message": "must be > 0",
                           "field": "fragment_groups[1].mass_kg.sigma_ln"}).encode()
        e = errors.from_response(422, body, method="POST", url="/v1/jobs")
        self.assertIsInstance(e, fragsim.Unprocessable)
        self.assertIsInstance(e, fragsim.FragsimError)
        self.assertEqual((e.status, e.code, e.message, e.field),
                         (422, "invalid_input", "must be > 0",
                          "fragment_groups[1].mass_kg.sigma_ln"))
        self.assertIn("fragment_groups[1].mass_kg.sigma_ln", str(e))
        lim = errors.from_response(422, b'{"code":"limit_exceeded","message":"m","field":null}')
        self.assertIsInstance(lim, fragsim.LimitExceeded)
        self.assertIsNone(lim.field)
        nr = errors.from_response(409, b'{"code":"not_ready","message":"queued","field":null}')
        self.assertIsInstance(nr, fragsim.NotReady)
        self.assertIsInstance(nr, fragsim.Conflict)
        # not_ready under another status is not NotReady
        self.assertIs(type(errors.from_response(400, b'{"code":"not_ready"}')), fragsim.BadRequest)
        self.assertIs(type(errors.from_response(502, b"<html>bad gateway</html>")),
                      fragsim.ServerError)
        self.assertIsInstance(errors.from_response(403, b'{"code":"forbidden","message":"m"}'),
                              fragsim.Forbidden)
        full = errors.from_response(507, b'{"code":"storage_full","message":"m","field":null}')
        self.assertIsInstance(full, fragsim.StorageFull)
        self.assertIsInstance(full, fragsim.ServerError)
        other = errors.from_response(418, b"teapot")
        self.assertIs(type(other), fragsim.ApiError)
        self.assertEqual((other.code, other.message), ("http_418", "teapot"))


class _Stub(http.server.BaseHTTPRequestHandler):
    """Answers from a script: a list of (status, headers, body) per path, used in turn."""

    script: Dict[str, List[Tuple[int, Dict[str, str], bytes]]] = {}
    seen: List[Tuple[str, str, Optional[str]]] = []

    def _answer(self):
        self.seen.append((self.command, self.path, self.headers.get("Authorization")))
        length = int(self.headers.get("Content-Length") or 0)
        if length:
            self.rfile.read(length)
        steps = self.script.get(self.path.split("?")[0], [(404, {}, b'{"code":"not_found"}')])
        status, headers, body = steps.pop(0) if len(steps) > 1 else steps[0]
        self.send_response(status)
        for k, v in headers.items():
            self.send_header(k, v)
        self.send_header("Content-Length", str(len(body)))
        self.end_headers()
        self.wfile.write(body)

    do_GET = do_POST = do_DELETE = _answer

    def log_message(self, *args):
        pass


class RetryAfterTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), _Stub)
        cls.thread = threading.Thread(target=cls.server.serve_forever, daemon=True)
        cls.thread.start()
        cls.url = f"http://127.0.0.1:{cls.server.server_address[1]}"

    @classmethod
    def tearDownClass(cls):
        cls.server.shutdown()
        cls.server.server_close()

    def setUp(self):
        _Stub.seen.clear()

    def test_busy_get_is_retried_after_retry_after(self):
        busy = (503, {"Retry-After": "0.2"}, b'{"code":"busy","message":"m","field":null}')
        _Stub.script = {"/v1/jobs/j_0000000000000001/report.html":
                        [busy, busy, (200, {}, b"<html>ok</html>")]}
        t0 = time.monotonic()
        text = fragsim.Client(self.url, "tok").report_html("j_0000000000000001")
        self.assertEqual(text, "<html>ok</html>")
        self.assertGreaterEqual(time.monotonic() - t0, 0.4)
        self.assertEqual(len(_Stub.seen), 3)
        self.assertEqual(_Stub.seen[0][2], "Bearer tok")

    def test_retries_are_bounded_and_the_last_error_raised(self):
        busy = (503, {"Retry-After": "0"}, b'{"code":"busy","message":"m","field":null}')
        _Stub.script = {"/v1/jobs/j_0000000000000001/report.pdf": [busy]}
        with tempfile.TemporaryDirectory() as d:
            with self.assertRaises(fragsim.ServiceUnavailable) as cm:
                fragsim.Client(self.url, "tok", retries=2).download_report_pdf(
                    "j_0000000000000001", Path(d) / "r.pdf")
            self.assertEqual(os.listdir(d), [])  # nothing half-written
        self.assertEqual((cm.exception.code, cm.exception.retry_after), ("busy", 0.0))
        self.assertEqual(len(_Stub.seen), 3)

    def test_a_post_is_not_retried_unless_refused_unread(self):
        busy = (503, {"Retry-After": "0"}, b'{"code":"busy","message":"m","field":null}')
        _Stub.script = {"/v1/jobs": [busy]}
        with self.assertRaises(fragsim.ServiceUnavailable):
            fragsim.Client(self.url, "tok").submit({"site_id": "s_0"})
        self.assertEqual(len(_Stub.seen), 1)
        full = (503, {"Retry-After": "0"},
                b'{"code":"too_many_connections","message":"m","field":null}')
        _Stub.script = {"/v1/jobs": [full, (202, {}, b'{"job_id":"j_1","state":"queued"}')]}
        job = fragsim.Client(self.url, "tok").submit({"site_id": "s_0"})
        self.assertEqual(job["job_id"], "j_1")

    def test_follow_backs_off_and_stops_at_a_final_state(self):
        running = json.dumps({"job_id": "j_1", "state": "running", "histories_done": 5,
                              "eta_s": None, "attempts": 1}).encode()
        done = json.dumps({"job_id": "j_1", "state": "done", "histories_done": 9,
                           "attempts": 1}).encode()
        _Stub.script = {"/v1/jobs/j_1": [(200, {}, running)] * 6 + [(200, {}, done)]}
        seen = list(fragsim.Client(self.url, "tok").follow("j_1", poll_s=0.01, max_poll_s=0.05))
        self.assertEqual([s["state"] for s in seen], ["running", "done"])  # changes only
        self.assertEqual(len(_Stub.seen), 7)

    def test_wait_times_out(self):
        queued = json.dumps({"job_id": "j_1", "state": "queued", "histories_done": 0}).encode()
        _Stub.script = {"/v1/jobs/j_1": [(200, {}, queued)]}
        with self.assertRaises(fragsim.WaitTimeout) as cm:
            fragsim.Client(self.url, "tok").wait("j_1", timeout=0.3, poll_s=0.05)
        self.assertEqual(cm.exception.status["state"], "queued")

    def test_token_from_the_environment_or_a_file(self):
        _Stub.script = {"/v1/health": [(200, {}, b'{"status":"ok"}')]}
        with mock.patch.dict(os.environ, {"FRAGSIM_TOKEN": "from-env"}):
            fragsim.Client(self.url).health()
        with tempfile.NamedTemporaryFile("w", suffix=".tokens") as f:
            f.write("# comment\n\nfrom-file\nsecond\n")
            f.flush()
            with mock.patch.dict(os.environ, {"FRAGSIM_TOKEN": ""}):
                fragsim.Client(self.url, token_file=f.name).health()
        self.assertEqual([s[2] for s in _Stub.seen], ["Bearer from-env", "Bearer from-file"])

    def test_no_answer_is_a_transport_error(self):
        with self.assertRaises(fragsim.TransportError):
            fragsim.Client("http://127.0.0.1:9", "tok", timeout=5).health()


class ResultsReaderRefusalTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = Path(tempfile.mkdtemp(prefix="fragsim-pytest-"))
        cli_run(MINIMAL, cls.tmp / "run")

    @classmethod
    def tearDownClass(cls):
        shutil.rmtree(cls.tmp, ignore_errors=True)

    def _copy_with(self, name, **attrs):
        import h5py

        path = self.tmp / name
        shutil.copy(self.tmp / "run" / "results.h5", path)
        with h5py.File(path, "r+") as f:
            for k, v in attrs.items():
                f.attrs[k] = v
        return path

    def test_unknown_format_version_is_refused_naming_it(self):
        path = self._copy_with("future.h5", format_version=np.int32(99))
        with self.assertRaises(fragsim.UnsupportedFormat) as cm:
            fragsim.results.open(path)
        self.assertIn("format_version 99", str(cm.exception))
        self.assertIn(str(path), str(cm.exception))

    def test_another_hdf5_file_and_a_text_file_are_refused(self):
        other = self._copy_with("other.h5", file_type=np.bytes_(b"something.else"))
        with self.assertRaisesRegex(fragsim.UnsupportedFormat, "not a fragsim results file"):
            fragsim.results.open(other)
        text = self.tmp / "summary.txt"
        text.write_text("{}")
        with self.assertRaisesRegex(fragsim.UnsupportedFormat, "not an HDF5 file"):
            fragsim.results.open(text)

    def test_the_reader_matches_summary_json(self):
        summary = json.loads((self.tmp / "run" / "summary.json").read_text())
        with fragsim.results.open(self.tmp / "run" / "results.h5") as r:
            self.assertEqual(r.format_version, 5)
            self.assertEqual(r.hfd.distance_m, summary["hazardous_fragment_distance_m"])
            self.assertEqual(list(r.hfd.band_m), summary["hazardous_fragment_distance_band_m"])
            self.assertEqual(list(r.hfd.by_sector_m), summary["hfd_by_sector_m"])
            self.assertEqual(r.hfd.bound, summary["hfd_bound"])
            self.assertEqual(r.hfd.by_sector_bound, summary["hfd_by_sector_bound"])
            self.assertEqual(r.attrs["seed"], summary["seed"])
            self.assertEqual(r.summary["hfd_by_sector_m"], summary["hfd_by_sector_m"])
            self.assertEqual(float(r.density_per_m2.max()), summary["max_ptn_density_per_m2"])
            m = summary["max_ptn_triangle"]
            self.assertEqual(list(r.centroids_m[m]), summary["max_ptn_location_m"])
            # the HFD is the largest horizontal distance of a hazardous centroid (docs/scenario.md)
            d = np.hypot(*(r.centroids_m[r.hazardous, :2] - r.hfd.origin_m[:2]).T)
            self.assertAlmostEqual(float(d.max()), r.hfd.distance_m, delta=1e-9)
            df = r.buildings()
            for row, b in zip(df.itertuples(), summary["buildings"]):
                self.assertEqual(row.id, b["id"])
                self.assertEqual(row.expected_impacts, b["expected_impacts"])
                self.assertEqual(row.impacts_std_error, b["impacts_std_error"])
                self.assertEqual(row.expected_penetrations, b["expected_penetrations"])
                self.assertEqual(row.penetrations_std_error, b["penetrations_std_error"])
                self.assertEqual(row.impacts_wall, b["by_surface"]["wall"]["expected_impacts"])
                self.assertEqual(row.residual_ke_j, b["residual_ke_j"])
            out = r.outcomes().set_index("name")
            for name, o in summary["outcomes"].items():
                self.assertEqual(out.loc[name, "histories"], o["histories"])
                self.assertEqual(out.loc[name, "fragments"], o["fragments"])
            frags = r.fragments()
            self.assertEqual(len(frags), summary["histories_done"])
            self.assertEqual(list(frags.columns[:2]), ["group", "history"])
            self.assertEqual(frags["weight"].sum(), summary["real_fragments"])
            self.assertEqual(int((frags["outcome_name"] == "building").sum()),
                             summary["outcomes"]["building"]["histories"])
            self.assertIsNone(r.trajectories())
            self.assertEqual(r.triangle_vertices_m.shape, (len(r.triangles), 3, 3))
            self.assertEqual(r.material_names, ["concrete_wall", "metal_roof", "soil"])


class SceneParserTest(unittest.TestCase):
    def _scene(self, header, data):
        h = json.dumps(header).encode()
        h += b" " * ((-(12 + len(h))) % 8)
        return b"FSSCENE1" + struct.pack("<I", len(h)) + h + data

    def test_arrays_are_read_at_their_offsets(self):
        v = np.arange(6, dtype="<f4")
        t = np.array([0, 1, 2], dtype="<u4")
        header = {"format": "fragsim.scene/1", "offset_m": [1.0, 2.0, 3.0], "arrays": {
            "terrain_vertices": {"type": "f32", "shape": [2, 3], "offset": 0, "bytes": 24},
            "terrain_triangles": {"type": "u32", "shape": [1, 3], "offset": 24, "bytes": 12},
            "future": {"type": "c64", "shape": [1], "offset": 0, "bytes": 8}}}
        s = fragsim.parse_scene(self._scene(header, v.tobytes() + t.tobytes() + b"\0" * 4))
        np.testing.assert_array_equal(s["terrain_vertices"], v.reshape(2, 3))
        np.testing.assert_array_equal(s["terrain_triangles"], [[0, 1, 2]])
        self.assertNotIn("future", s.arrays)
        np.testing.assert_array_equal(s.offset_m, [1.0, 2.0, 3.0])

    def test_damaged_scenes_are_refused(self):
        with self.assertRaises(fragsim.UnsupportedFormat):
            fragsim.parse_scene(b"NOTSCENE" + b"\0" * 8)
        header = {"arrays": {"a": {"type": "f32", "shape": [4], "offset": 0, "bytes": 16}}}
        with self.assertRaisesRegex(fragsim.UnsupportedFormat, "past the end"):
            fragsim.parse_scene(self._scene(header, b"\0" * 8))


if __name__ == "__main__":
    unittest.main()
