#!/usr/bin/python3
"""The OpenAPI contract tested from outside, against a live fragsimd (docs/testing.md).

    tests/server/contract_test.py --fragsimd build/server/fragsimd [--keep]

Starts fragsimd on a free loopback port (temporary data directory, a token file, small limits so
that every refusal is cheap to provoke), fetches the document it serves at GET /v1/openapi.yaml,
and then:

1. checks the document itself: each inlined `scenario.*` component equals its definition in
   api/schema/scenario.schema.json (the one source); JobRequest carries every scenario key; every
   operation declares the statuses the daemon answers on any route (400, 405, 408, 411, 413,
   414, 431, 500, 503; 401 where a token is needed; 404 where the path holds an id); every error
   code the server's sources send is in the Error enum; no schema is a bare `type: object`
   (except the free-form ones listed in FREE_FORM, each with its reason);
2. drives every operation of the document through the statuses it can provoke (200, 201, 202,
   204, 400, 401, 403 with a token of role read, 404, 405, 408, 409, 411, 413, 414, 415, 422,
   431, 503, and 507 on a second daemon whose --min-free-bytes no disk meets) and validates each
   answer: the status is declared for that operation, its media type is declared, and its body
   validates against the declared schema (JSON Schema 2020-12, python3-jsonschema);
3. fails if an operation was not exercised, or a declared status was not provoked and is not in
   NOT_PROVOKED with a reason.

The daemon is killed at the end, also on failure. Python 3 with Debian's python3-yaml and
python3-jsonschema (deploy/install-deps.sh).
"""
import argparse
import copy
import gzip
import http.client
import json
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
import traceback
import urllib.parse

import jsonschema
import yaml

HERE = os.path.dirname(os.path.abspath(__file__))
SOURCE = os.path.abspath(os.path.join(HERE, "..", ".."))
TOKEN = "contract-test-token-0123456789"  # no role in the token file: admin
READER = "contract-test-reader-0123456789"  # role read: 403 on every change
MAX_BODY = 4 << 20  # --max-body-bytes: a 413 needs only its Content-Length
MAX_CONNECTIONS = 8

# Statuses the daemon answers on every route, before or outside the route's own logic.
ANY_ROUTE = {"400", "405", "408", "411", "413", "414", "431", "500", "503"}

# Schemas that are objects on purpose without properties/additionalProperties, as
# {"#/pointer/in/the/document": "reason"}. None today: even the map files' GeoJSON names its type.
FREE_FORM = {}

# Declared statuses this test does not provoke, by operation ('*' = every one), with the reason.
NOT_PROVOKED = {
    ("*", "500"): "a genuine fault of the daemon: nothing a client sends provokes it",
    ("retryJob", "202"): "needs a failed job that may be retried (a full disk, a crash): "
                         "ServiceDisk.AJobThatMeetsAFullDiskFailsAsStorageFullAndIsDoneWhenRetried",
    ("retryJob", "507"): "needs a failed job and a short disk at once: ServiceDisk.* provoke both",
    ("getJobReportHtml", "503"): "busy needs a second report in the making for 5 s",
    ("getJobReportPdf", "503"): "busy needs a second report in the making for 5 s",
}


# ---- the document ------------------------------------------------------------------------------

def pointer(*parts):
    return "#/" + "/".join(str(p).replace("~", "~0").replace("/", "~1") for p in parts)


def resolve(doc, node):
    """A `$ref` to a place in the document, followed (with its pointer)."""
    ptr = None
    while isinstance(node, dict) and "$ref" in node and len(node) == 1:
        ptr = node["$ref"]
        assert ptr.startswith("#/"), ptr
        node = doc
        for part in ptr[2:].split("/"):
            node = node[part.replace("~1", "/").replace("~0", "~")]
    return node, ptr


def operations(doc):
    for path, item in doc["paths"].items():
        for method in ("get", "post", "put", "patch", "delete"):
            if method in item:
                yield path, method, item[method]


def rewrite_refs(node, old, new):
    if isinstance(node, dict):
        return {k: (v.replace(old, new, 1) if k == "$ref" and isinstance(v, str) else
                    rewrite_refs(v, old, new)) for k, v in node.items()}
    if isinstance(node, list):
        return [rewrite_refs(v, old, new) for v in node]
    return node


def check_document(doc, errors):
    schemas = doc["components"]["schemas"]
    with open(os.path.join(SOURCE, "api/schema/scenario.schema.json")) as f:
        scenario = json.load(f)
    # The inlined copies equal the source (numbers compared as values: CMake re-serialises them).
    for name, definition in scenario["$defs"].items():
        want = rewrite_refs(definition, "#/$defs/", "#/components/schemas/scenario.")
        if schemas.get("scenario." + name) != want:
            errors.append(f"components/schemas/scenario.{name} differs from $defs/{name} of "
                          "api/schema/scenario.schema.json: rebuild (cmake) to re-inline it")
    extra = {k for k in schemas if k.startswith("scenario.")} - {
        "scenario." + k for k in scenario["$defs"]}
    if extra:
        errors.append(f"components not in the scenario schema: {sorted(extra)}")
    job_keys = set(schemas["JobRequest"]["properties"])
    missing = set(scenario["$defs"]["scenario"]["properties"]) - job_keys
    if missing:
        errors.append(f"JobRequest lacks the scenario keys {sorted(missing)}")

    # Every operation declares what the daemon answers on any route.
    for path, method, op in operations(doc):
        want = set(ANY_ROUTE)
        if op.get("security", doc.get("security")) != []:
            want.add("401")
        if "{" in path:
            want.add("404")
        lacking = want - set(op["responses"])
        if lacking:
            errors.append(f"{method.upper()} {path} does not declare {sorted(lacking)}")

    # Every error code the server sends is in the Error enum.
    sent, failed = set(), set()
    for name in os.listdir(os.path.join(SOURCE, "server")):
        if name.endswith(".cpp"):
            with open(os.path.join(SOURCE, "server", name)) as f:
                text = f.read()
            sent |= set(re.findall(r'error_response\(\s*[^,]+,\s*"([a-z_]+)"', text))
            failed |= set(re.findall(r'mark_failed\([^,]+,[^,]+,\s*"([a-z_]+)"', text))
    declared = set(schemas["Error"]["properties"]["code"]["enum"])
    if sent - declared:
        errors.append(f"error codes sent but not in the Error enum: {sorted(sent - declared)}")
    # And every code a failed job's `error` can hold is in JobStatus.error's enum.
    job_codes = set(schemas["JobStatus"]["properties"]["error"]["properties"]["code"]["enum"])
    if not failed or failed - job_codes:
        errors.append(f"job error codes not in JobStatus.error: {sorted(failed - job_codes)}")

    # No bare object schema: walk every schema of the document.
    def walk(node, ptr):
        if isinstance(node, dict):
            types = node.get("type")
            types = types if isinstance(types, list) else [types]
            shaped = any(k in node for k in ("properties", "additionalProperties",
                                             "patternProperties", "allOf", "oneOf", "anyOf",
                                             "$ref", "unevaluatedProperties"))
            if "object" in types and not shaped and ptr not in FREE_FORM:
                errors.append(f"bare object schema at {ptr}")
            for k, v in node.items():
                walk(v, ptr + "/" + str(k).replace("~", "~0").replace("/", "~1"))
        elif isinstance(node, list):
            for i, v in enumerate(node):
                walk(v, f"{ptr}/{i}")
    walk(doc["paths"], "#/paths")
    walk(doc["components"], "#/components")
    for ptr in FREE_FORM:
        if not ptr.startswith("#/") or ptr.split("/")[1] not in ("paths", "components"):
            errors.append(f"FREE_FORM lists {ptr}, not a place in the document")


# ---- the daemon --------------------------------------------------------------------------------

class Daemon:
    def __init__(self, binary, workdir, extra=()):
        self.dir = workdir
        with open(os.path.join(workdir, "tokens"), "w") as f:
            f.write(f"# contract test\n{TOKEN}\n{READER} read\n")
        self.log = open(os.path.join(workdir, "fragsimd.log"), "w")
        port_file = os.path.join(workdir, "port")
        self.proc = subprocess.Popen(
            [binary, "--listen", "127.0.0.1:0", "--port-file", port_file,
             "--data-dir", os.path.join(workdir, "data"),
             "--token-file", os.path.join(workdir, "tokens"), "--threads", "1",
             "--max-body-bytes", str(MAX_BODY), "--max-sites", "2",
             "--max-samples-per-job", "10000000", "--max-connections", str(MAX_CONNECTIONS),
             "--request-timeout-s", "1", "--log-level", "warn", *extra],
            stdout=self.log, stderr=self.log, start_new_session=True)
        deadline = time.monotonic() + 20
        while time.monotonic() < deadline:
            if self.proc.poll() is not None:
                raise RuntimeError(f"fragsimd exited with {self.proc.returncode}; log in {workdir}")
            try:
                with open(port_file) as f:
                    self.port = int(f.read().strip())
                return
            except (OSError, ValueError):
                time.sleep(0.02)
        raise RuntimeError("fragsimd did not write its port within 20 s")

    def stop(self):
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self.log.close()


class Answer:
    def __init__(self, status, headers, body):
        self.status = status
        self.headers = {k.lower(): v for k, v in headers}
        self.body = body

    def json(self):
        return json.loads(self.body)


# ---- the contract test -------------------------------------------------------------------------

class Contract:
    def __init__(self, daemon, doc):
        self.daemon = daemon
        self.doc = doc
        self.errors = []
        self.seen = {}  # operationId -> set of statuses answered
        self.validators = {}
        self.routes = []  # (regex, path template) longest literal first
        for path in doc["paths"]:
            rx = "^" + re.sub(r"\\\{[a-z_]+\\\}", "[^/]+", re.escape(path)) + "$"
            self.routes.append((re.compile(rx), path))

    # -- transport
    def request(self, method, path, body=None, headers=None, token=True):
        """token: True (the admin token), False (none) or a token."""
        hdrs = dict(headers or {})
        if token:
            hdrs.setdefault("Authorization", f"Bearer {TOKEN if token is True else token}")
        if body is not None and not isinstance(body, (bytes, str)):
            body = json.dumps(body)
            hdrs.setdefault("Content-Type", "application/json")
        conn = http.client.HTTPConnection("127.0.0.1", self.daemon.port, timeout=60)
        try:
            conn.request(method, path, body=body, headers=hdrs)
            r = conn.getresponse()
            return Answer(r.status, r.getheaders(), r.read())
        finally:
            conn.close()

    def raw(self, data, wait_s=0.0):
        """Bytes sent as they are; the answer read until the daemon closes the connection."""
        with socket.create_connection(("127.0.0.1", self.daemon.port), timeout=5) as s:
            s.sendall(data)
            if wait_s:
                time.sleep(wait_s)
            chunks = []
            while True:
                try:
                    c = s.recv(65536)
                except (ConnectionResetError, socket.timeout):
                    break
                if not c:
                    break
                chunks.append(c)
        return parse_raw(b"".join(chunks))

    # -- checks
    def operation(self, method, url):
        path = urllib.parse.urlsplit(url).path
        for rx, template in self.routes:
            if rx.match(path):
                item = self.doc["paths"][template]
                if method.lower() in item:
                    return template, item[method.lower()]
                # Another method: the 405 belongs to every operation of the path.
                return template, next(item[m] for m in ("get", "post", "delete") if m in item)
        raise AssertionError(f"{url} matches no path of the document")

    def check(self, method, url, answer, expect):
        template, op = self.operation(method, url)
        name = f"{method} {url}"
        status = str(answer.status)
        if answer.status == 405:  # the 405 of a path belongs to each of its operations
            for other in self.doc["paths"][template].values():
                if isinstance(other, dict) and "operationId" in other:
                    self.seen.setdefault(other["operationId"], set()).add(status)
        self.seen.setdefault(op["operationId"], set()).add(status)
        if answer.status != expect:
            self.errors.append(f"{name}: expected {expect}, got {status}: {answer.body[:300]!r}")
        declared = op["responses"].get(status)
        if declared is None:
            self.errors.append(f"{name}: status {status} not declared for {op['operationId']}")
            return
        response, resp_ptr = resolve(self.doc, declared)
        base = resp_ptr or pointer("paths", template, method.lower() if method.lower() in
                                   self.doc["paths"][template] else "get", "responses", status)
        # The headers the response declares are sent (Location, Allow, WWW-Authenticate,
        # Retry-After, Content-Disposition, ...).
        for header in response.get("headers", {}):
            if header.lower() not in answer.headers:
                self.errors.append(f"{name}: {status} lacks the declared header {header}")
        content = response.get("content")
        if not content:
            if answer.body:
                self.errors.append(f"{name}: {status} declares no body, got {answer.body[:80]!r}")
            return
        ctype = answer.headers.get("content-type", "")
        media = match_media(ctype, content)
        if media is None:
            self.errors.append(f"{name}: {status} Content-Type {ctype!r} not declared "
                               f"(declared: {sorted(content)})")
            return
        schema = content[media].get("schema")
        if schema is None:
            return
        body = answer.body
        if answer.headers.get("content-encoding") == "gzip":
            body = gzip.decompress(body)
        if is_json(media):
            try:
                value = json.loads(body)
            except ValueError as e:
                self.errors.append(f"{name}: {status} body is not JSON ({e})")
                return
        elif media.startswith("text/") or media == "application/yaml" or media.endswith("+xml"):
            value = body.decode("utf-8")
        else:
            if not body:
                self.errors.append(f"{name}: {status} empty {media} body")
            return
        self.validate(name, status, schema, base + "/content/" + media.replace("/", "~1"), value)

    def validate(self, name, status, schema, where, value):
        key = json.dumps(schema, sort_keys=True)
        if key not in self.validators:
            root = dict(schema)
            root["components"] = self.doc["components"]  # "#/components/..." resolves in it
            self.validators[key] = jsonschema.Draft202012Validator(
                root, format_checker=jsonschema.Draft202012Validator.FORMAT_CHECKER)
        errs = sorted(self.validators[key].iter_errors(value), key=lambda e: list(e.path))
        for e in errs[:3]:
            at = "".join(f"[{p!r}]" for p in e.path)
            self.errors.append(f"{name}: {status} body{at} does not match {where}: "
                               f"{e.message[:300]}")
        # Keys sent that the document does not name (a schema may leave an object open for
        # later keys, so validation alone would pass them): each is a gap in the contract.
        for at in sorted(set(undeclared(self.doc, schema, value, "")))[:5]:
            self.errors.append(f"{name}: {status} sends body{at}, not in {where}")

    def call(self, method, url, expect, body=None, headers=None, token=True):
        if isinstance(body, dict) and expect < 300:  # what is accepted must be valid, both ways
            template, op = self.operation(method, url)
            schema = op["requestBody"]["content"]["application/json"]["schema"]
            self.validate(f"{method} {url}", "request", schema,
                          pointer("paths", template, method.lower(), "requestBody"), body)
        answer = self.request(method, url, body, headers, token)
        self.check(method, url, answer, expect)
        return answer

    def call_raw(self, method, url, data, expect, wait_s=0.0):
        answer = self.raw(data, wait_s)
        self.check(method, url, answer, expect)
        return answer


def branches(doc, schema):
    """The schema and everything it is made of ($ref, allOf, oneOf, anyOf), flattened."""
    out, todo = [], [schema]
    while todo:
        node = todo.pop()
        if not isinstance(node, dict):
            continue
        out.append(node)
        if "$ref" in node:
            todo.append(resolve(doc, {"$ref": node["$ref"]})[0])
        for k in ("allOf", "oneOf", "anyOf"):
            todo.extend(node.get(k, []))
    return out


def undeclared(doc, schema, value, at):
    """Paths of object keys in `value` that no branch of `schema` names (open objects aside)."""
    parts = branches(doc, schema)
    if isinstance(value, dict):
        named = {}
        open_ = False
        for b in parts:
            for k, sub in b.get("properties", {}).items():
                named.setdefault(k, sub)
            extra = b.get("additionalProperties")
            if isinstance(extra, dict):
                for k, v in value.items():
                    if k not in named:
                        yield from undeclared(doc, extra, v, f"{at}[{k!r}]")
                open_ = True
            elif extra is True or "patternProperties" in b:
                open_ = True
        if not named and not open_:
            return  # a schema with no say about keys (e.g. a bare string field)
        for k, v in value.items():
            if k in named:
                yield from undeclared(doc, named[k], v, f"{at}[{k!r}]")
            elif not open_:
                yield f"{at}[{k!r}]"
    elif isinstance(value, list):
        for b in parts:
            if isinstance(b.get("items"), dict):
                for i, v in enumerate(value[:50]):
                    yield from undeclared(doc, b["items"], v, f"{at}[{i}]")
                return


def parse_raw(data):
    head, _, body = data.partition(b"\r\n\r\n")
    lines = head.decode("latin-1").split("\r\n")
    if not lines or not lines[0].startswith("HTTP/1.1 "):
        raise AssertionError(f"no HTTP answer: {data[:200]!r}")
    status = int(lines[0].split()[1])
    headers = [tuple(x.strip() for x in line.split(":", 1)) for line in lines[1:] if ":" in line]
    hd = {k.lower(): v for k, v in headers}
    if hd.get("transfer-encoding") == "chunked":
        out, rest = b"", body
        while rest:
            size_line, _, rest = rest.partition(b"\r\n")
            size = int(size_line.split(b";")[0], 16)
            if size == 0:
                break
            out, rest = out + rest[:size], rest[size + 2:]
        body = out
    elif "content-length" in hd:
        body = body[:int(hd["content-length"])]
    return Answer(status, headers, body)


def match_media(ctype, content):
    base = ctype.split(";")[0].strip().lower()
    params = {p.strip().lower() for p in ctype.split(";")[1:] if p.strip()}
    for media in content:
        m_base = media.split(";")[0].strip().lower()
        m_params = {p.strip().lower() for p in media.split(";")[1:] if p.strip()}
        if m_base == base and m_params <= params:
            return media
    return None


def is_json(media):
    base = media.split(";")[0].strip()
    return base == "application/json" or base.endswith("+json")


# ---- the scenario of the test ------------------------------------------------------------------

def small_site(cell_m=100.0, crs="EPSG:32611"):
    with open(os.path.join(SOURCE, "examples/minimal/scenario.json")) as f:
        site = json.load(f)["site"]
    site["origin"] = {"crs": crs, "easting_m": 452300, "northing_m": 3839800, "elevation_m": 400}
    site["terrain"]["plane"] = {"elevation_m": 0, "extent_m": [-600, -600, 600, 600],
                                "cell_m": cell_m}
    return site


def job_body(site_id, samples, **extra):
    with open(os.path.join(SOURCE, "examples/minimal/scenario.json")) as f:
        scenario = json.load(f)
    del scenario["site"]
    scenario["site_id"] = site_id
    scenario["fragment_groups"][0]["samples"] = samples
    scenario["settings"]["record_trajectories"] = True
    scenario.update(extra)
    return scenario


def wait_state(c, job, states, timeout_s=60):
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        a = c.request("GET", f"/v1/jobs/{job}")
        if a.json()["state"] in states:
            return a
        time.sleep(0.05)
    raise AssertionError(f"job {job} not {states} within {timeout_s} s")


def exercise(c):
    """Every operation through the statuses it can provoke; each answer checked by c.check."""
    unknown_job, unknown_site = "j_0000000000000000", "s_0000000000000000"

    # Sites.
    site_a = c.call("POST", "/v1/sites", 201, small_site()).json()["site_id"]
    c.call("POST", "/v1/sites", 200, small_site())
    site_b = c.call("POST", "/v1/sites", 201, small_site(cell_m=120.0)).json()["site_id"]
    c.call("POST", "/v1/sites", 422, small_site(cell_m=150.0))  # limit_exceeded: --max-sites 2
    bad_site = small_site()
    bad_site["terrain"]["plane"]["cell_m"] = -1
    c.call("POST", "/v1/sites", 422, bad_site)
    c.call("POST", "/v1/sites", 400, "{\"terrain\": ", {"Content-Type": "application/json"})
    c.call("POST", "/v1/sites", 400, "[" * 100 + "]" * 100, {"Content-Type": "application/json"})
    c.call("POST", "/v1/sites", 415, json.dumps(small_site()), {"Content-Type": "text/plain"})
    c.call("GET", "/v1/sites", 200)
    c.call("GET", f"/v1/sites/{site_a}", 200)
    c.call("GET", f"/v1/sites/{unknown_site}", 404)
    c.call("GET", "/v1/sites/not-an-id", 404)
    c.call("GET", f"/v1/sites/{site_a}/scene", 200)
    c.call("GET", f"/v1/sites/{unknown_site}/scene", 404)
    c.call("POST", "/v1/sites", 403, small_site(cell_m=90.0), token=READER)  # role read
    c.call("GET", "/v1/whoami", 200)
    c.call("GET", "/v1/whoami", 200, token=READER)

    # A done job (UTM 11N: every map file, GeoJSON and KML included).
    accepted = c.call("POST", "/v1/jobs", 202, job_body(site_a, 300, idempotency_key="k-1")).json()
    done = accepted["job_id"]
    c.call("POST", "/v1/jobs", 200, job_body(site_a, 300, idempotency_key="k-1"))
    c.call("POST", "/v1/jobs", 409, job_body(site_a, 301, idempotency_key="k-1"))
    c.call("POST", "/v1/jobs", 422, job_body(unknown_site, 300))
    c.call("POST", "/v1/jobs", 422, job_body(site_a, 20000000))  # limit_exceeded: samples
    c.call("POST", "/v1/jobs", 400, "{", {"Content-Type": "application/json"})
    c.call("POST", "/v1/jobs", 415, json.dumps(job_body(site_a, 300)), {"Content-Type": "text/csv"})
    c.call("POST", "/v1/jobs", 403, job_body(site_a, 300), token=READER)
    inline = job_body(site_a, 200)
    del inline["site_id"]
    inline["site"] = small_site(crs="local")
    inline_job = c.call("POST", "/v1/jobs", 202, inline).json()["job_id"]
    # The kitchen sink (every object kind of the scenario; settings.precision, ground_bracket,
    # profile) inline: its request is valid against JobRequest, its results fill every block.
    with open(os.path.join(SOURCE, "tests/api/data/kitchen_sink.json")) as f:
        sink = c.call("POST", "/v1/jobs", 202, json.load(f)).json()["job_id"]
    wait_state(c, done, {"done"})
    wait_state(c, inline_job, {"done"})
    wait_state(c, sink, {"done"})
    for route in ("summary", "buildings", "ptn", "plan_boundary", "scene", "maps"):
        c.call("GET", f"/v1/jobs/{sink}/{route}", 200)

    # A long job on site B: running, then the site cannot go, then cancelled.
    long_job = c.call("POST", "/v1/jobs", 202, job_body(site_b, 5000000)).json()["job_id"]
    wait_state(c, long_job, {"running"})
    time.sleep(0.3)  # some progress: histories_per_s and eta_s are numbers
    c.call("GET", f"/v1/jobs/{long_job}", 200)
    c.call("DELETE", f"/v1/sites/{site_b}", 409)
    c.call("DELETE", f"/v1/sites/{site_b}", 403, token=READER)
    c.call("DELETE", f"/v1/jobs/{long_job}", 403, token=READER)
    c.call("GET", f"/v1/jobs/{long_job}/summary", 409)  # not_ready
    c.call("DELETE", f"/v1/jobs/{long_job}?purge=true", 409)  # running: cancel it first
    c.call("DELETE", f"/v1/jobs/{long_job}", 200)
    c.call("DELETE", f"/v1/jobs/{long_job}", 409)
    c.call("DELETE", f"/v1/jobs/{unknown_job}", 404)
    c.call("DELETE", f"/v1/sites/{site_b}", 204)
    c.call("DELETE", f"/v1/sites/{site_b}", 404)
    # A finished job purged with its files (docs/operations.md, "Retention"); then it is gone.
    purged = c.call("POST", "/v1/jobs", 202, job_body(site_a, 100)).json()["job_id"]
    wait_state(c, purged, {"done"})
    c.call("DELETE", f"/v1/jobs/{purged}?purge=maybe", 400)
    c.call("DELETE", f"/v1/jobs/{purged}?purge=true", 200)
    c.call("DELETE", f"/v1/jobs/{purged}?purge=true", 404)
    c.call("GET", f"/v1/jobs/{purged}", 404)

    c.call("GET", "/v1/jobs", 200)
    c.call("GET", "/v1/jobs?state=done&limit=5", 200)
    c.call("GET", "/v1/jobs?state=finished", 400)
    c.call("GET", "/v1/jobs?limit=0", 400)
    c.call("GET", f"/v1/jobs/{done}", 200)
    c.call("GET", f"/v1/jobs/{unknown_job}", 404)
    c.call("POST", f"/v1/jobs/{done}/retry", 409)  # done: only a failed job is retried
    c.call("POST", f"/v1/jobs/{done}/retry", 403, token=READER)
    c.call("POST", f"/v1/jobs/{unknown_job}/retry", 404)

    # The results of the done job, and of the cancelled one (409 not_ready), and unknown ids.
    results = {
        "summary": [("", 200)],
        "buildings": [("", 200)],
        "ptn": [("", 200), ("?format=geojson&min_density_per_m2=0.001", 200),
                ("?format=csv", 400), ("?min_density_per_m2=1", 400)],
        "plan_boundary": [("", 200), ("?smoothing_m=30", 200), ("?smoothing_m=-1", 400)],
        "results.h5": [("", 200)],
        "scene": [("", 200), ("?max_trajectories=3", 200), ("?max_trajectories=-1", 400)],
        "maps": [("", 200)],
        "report.html": [("", 200), ("?units=us", 200), ("?units=imperial", 400)],
        "report.pdf": [("", None)],  # 200 with chromium, else 503 pdf_unavailable
    }
    for route, cases in results.items():
        for query, expect in cases:
            url = f"/v1/jobs/{done}/{route}{query}"
            if expect is None:
                a = c.request("GET", url)
                expect = a.status if a.status in (200, 503) else 200
                c.check("GET", url, a, expect)
            else:
                c.call("GET", url, expect)
        c.call("GET", f"/v1/jobs/{long_job}/{route}", 409)
        c.call("GET", f"/v1/jobs/{unknown_job}/{route}", 404)
    # A paired comparison (docs/comparison.md): a variant of the done job with compare_with; its
    # JobStatus links the comparison, GET compare and compare.h5 answer; a job without one 404,
    # a variant that cannot be paired 422.
    variant = job_body(site_a, 300, compare_with=done)
    variant["atmosphere"] = {"model": "isa", "wind_mps": [3, 0, 0]}
    compared = c.call("POST", "/v1/jobs", 202, variant).json()["job_id"]
    c.call("POST", "/v1/jobs", 422, job_body(site_a, 301, compare_with=done))
    c.call("POST", "/v1/jobs", 422, job_body(site_a, 300, compare_with=unknown_job))
    status = wait_state(c, compared, {"done"})
    c.check("GET", f"/v1/jobs/{compared}", status, 200)
    maps = c.call("GET", f"/v1/jobs/{compared}/maps", 200).json()
    assert "density_difference.tif" in [f["name"] for f in maps["files"]], maps
    c.call("GET", f"/v1/jobs/{compared}/maps/density_difference.tif", 200)
    for route in ("compare", "compare.h5"):
        c.call("GET", f"/v1/jobs/{compared}/{route}", 200)
        c.call("GET", f"/v1/jobs/{done}/{route}", 404)
        c.call("GET", f"/v1/jobs/{long_job}/{route}", 409)
        c.call("GET", f"/v1/jobs/{unknown_job}/{route}", 404)
    c.call("GET", f"/v1/jobs/{inline_job}/ptn?format=geojson", 200)  # site metres, no CRS
    c.call("GET", f"/v1/jobs/{inline_job}/maps", 200)
    listing = c.request("GET", f"/v1/jobs/{done}/maps").json()
    for f in listing["files"]:
        c.call("GET", f["url"], 200)
    c.call("GET", f"/v1/jobs/{done}/maps/nothing.tif", 404)
    c.call("GET", f"/v1/jobs/{long_job}/maps/ptn_density.tif", 409)
    c.call("GET", f"/v1/jobs/{unknown_job}/maps/ptn_density.tif", 404)

    c.call("GET", "/v1/health", 200)
    c.call("GET", "/v1/health", 200, headers={"Range": "bytes=0-10"})  # ignored: the whole body
    c.call("GET", f"/v1/jobs/{done}/summary", 200, headers={"Range": "bytes=5-"})
    c.call("GET", "/v1/openapi.yaml", 200)
    c.call("GET", "/metrics", 200)

    # Every operation: 401 without a token, 400 for an unknown query parameter, 405 for a method
    # of no operation of the path, 411, 413, 431 (the connection layer).
    urls = {}
    for path, method, op in operations(c.doc):
        url = path.replace("{id}", done if path.startswith("/v1/jobs/") else site_a)
        url = url.replace("{name}", "ptn_density.tif")
        urls[(path, method)] = url
        verb = method.upper()
        sep = "&" if "?" in url else "?"
        if op.get("security", c.doc.get("security")) != []:
            c.call(verb, url, 401, token=False)
        c.call(verb, url + sep + "colour=red", 400)
        c.call(verb, url + sep + "x=" + "a" * 9000, 414)
        others = [m for m in ("PUT", "PATCH") if m.lower() not in c.doc["paths"][path]]
        c.call(others[0], url, 405)
        auth = f"Authorization: Bearer {TOKEN}\r\n"
        c.call_raw(verb, url, (f"{verb} {url} HTTP/1.1\r\nHost: x\r\n{auth}"
                               "Transfer-Encoding: chunked\r\n\r\n").encode(), 411)
        c.call_raw(verb, url, (f"{verb} {url} HTTP/1.1\r\nHost: x\r\n{auth}Content-Type: "
                               f"application/json\r\nContent-Length: {MAX_BODY + 1}\r\n\r\n{{")
                   .encode(), 413)
        pad = "".join(f"X-Pad-{i}: {'a' * 7000}\r\n" for i in range(10))  # 70 kB, no line > 8 KiB
        c.call_raw(verb, url, f"{verb} {url} HTTP/1.1\r\nHost: x\r\n{pad}\r\n".encode(), 431)
    # A header line above cpp-httplib's 8 KiB: 400 bad_request (on any route; once here).
    c.call_raw("GET", "/v1/health", ("GET /v1/health HTTP/1.1\r\nHost: x\r\nConnection: close\r\n"
                                      f"X-Pad: {'a' * 9000}\r\n\r\n").encode(), 400)

    # 503 too_many_connections: every operation while the daemon holds its most connections.
    held = saturate(c)
    try:
        for (path, method), url in urls.items():
            verb = method.upper()
            c.call_raw(verb, url, f"{verb} {url} HTTP/1.1\r\nHost: x\r\nConnection: close\r\n"
                       "\r\n".encode(), 503)
    finally:
        for s in held:
            s.close()
    time.sleep(0.2)

    # 408 request_timeout (--request-timeout-s 1): one operation's headers never finished; the
    # connection layer answers it the same on every route.
    for (path, method), url in list(urls.items())[:1]:
        verb = method.upper()
        c.call_raw(verb, url, f"{verb} {url} HTTP/1.1\r\nHost: x\r\n".encode(), 408, wait_s=1.5)


def short_disk(c, binary, work):
    """507 storage_full: a second daemon whose free-space guard no disk can meet."""
    os.makedirs(work)
    second = Daemon(binary, work, ("--min-free-bytes", str(1 << 62)))
    first, c.daemon = c.daemon, second
    try:
        c.call("POST", "/v1/sites", 507, small_site())
        inline = job_body("s_0000000000000000", 100)
        del inline["site_id"]
        inline["site"] = small_site(crs="local")
        c.call("POST", "/v1/jobs", 507, inline)
    finally:
        c.daemon = first
        second.stop()


def saturate(c):
    """Keep-alive connections opened until the daemon refuses one: then it holds its most.

    (It still counts a connection of ours it has not yet seen close, so MAX_CONNECTIONS new ones
    may be one too many or too few for a moment; a refused one is not counted.)"""
    held = []
    for _ in range(MAX_CONNECTIONS + 8):
        s = socket.create_connection(("127.0.0.1", c.daemon.port), timeout=5)
        s.sendall(b"GET /v1/health HTTP/1.1\r\nHost: x\r\n\r\n")
        answer = b""
        while b"\r\n\r\n" not in answer or not answer.rstrip().endswith(b"}"):
            piece = s.recv(65536)
            if not piece:
                break
            answer += piece
        if answer.startswith(b"HTTP/1.1 503"):
            s.close()
            return held
        held.append(s)
    raise AssertionError(f"fragsimd took {len(held)} connections with --max-connections "
                         f"{MAX_CONNECTIONS}")


def coverage(c):
    """Operations never exercised; declared statuses never provoked and not excused."""
    out = []
    for path, method, op in operations(c.doc):
        oid = op["operationId"]
        seen = c.seen.get(oid, set())
        if not seen:
            out.append(f"{oid}: never exercised")
            continue
        for status in op["responses"]:
            if status in seen or ("*", status) in NOT_PROVOKED or (oid, status) in NOT_PROVOKED:
                continue
            if status == "408":  # provoked once (the connection layer's, the same on every route)
                continue
            out.append(f"{oid}: declared {status} never provoked")
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--fragsimd", required=True)
    ap.add_argument("--keep", action="store_true", help="keep the data directory and log")
    args = ap.parse_args()
    signal.signal(signal.SIGPIPE, signal.SIG_DFL)
    t0 = time.monotonic()
    work = tempfile.mkdtemp(prefix="fragsim-contract-")
    daemon = None
    ok = False
    try:
        daemon = Daemon(args.fragsimd, work)
        first = Contract(daemon, {"paths": {}})
        served = first.request("GET", "/v1/openapi.yaml", token=False)
        assert served.status == 200, served.status
        doc = yaml.safe_load(served.body)
        assert doc["openapi"].startswith("3.1"), doc["openapi"]
        c = Contract(daemon, doc)
        check_document(doc, c.errors)
        exercise(c)
        short_disk(c, args.fragsimd, os.path.join(work, "short"))
        c.errors += coverage(c)
        for _, _, op in operations(doc):
            print(f"  {op['operationId']}: " + " ".join(sorted(c.seen.get(op["operationId"], ()))))
        for e in c.errors:
            print("FAIL", e)
        n = sum(len(s) for s in c.seen.values())
        print(f"contract: {len(c.seen)} operations, {n} (operation, status) pairs answered, "
              f"{len(c.errors)} failures, {time.monotonic() - t0:.1f} s")
        ok = not c.errors
    except Exception:  # the daemon is stopped below whatever went wrong
        traceback.print_exc()
    finally:
        if daemon:
            daemon.stop()
        if not ok or args.keep:
            print(f"contract: daemon log and data in {work}")
        else:
            shutil.rmtree(work, ignore_errors=True)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
