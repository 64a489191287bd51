"""HTTP client of fragsimd (docs/http-api.md), standard library only.

One method per route; JSON answers come back as dicts (numbers as Python floats and ints, arrays
of the PTN route as numpy arrays), files are downloaded to a path (written under a temporary
name, then renamed: a failed download leaves nothing under the final name). Error answers raise
the exceptions of :mod:`fragsim.errors`.
"""

from __future__ import annotations

import gzip
import json
import os
import re
import time
import urllib.error
import urllib.parse
import urllib.request
import zlib
from pathlib import Path
from typing import (
    IO,
    Any,
    Callable,
    Dict,
    Iterator,
    List,
    Mapping,
    Optional,
    Sequence,
    Tuple,
    Union,
    cast,
)

import numpy as np

from . import errors
from ._version import API_VERSION, __version__
from .scene import Scene, parse_scene

PathLike = Union[str, "os.PathLike[str]"]
#: A scenario or site: a dict, or the path of a JSON file holding it.
JsonSource = Union[Mapping[str, Any], PathLike]
JobStatus = Dict[str, Any]

FINAL_STATES = ("done", "failed", "cancelled")


def load_json(source: JsonSource) -> Dict[str, Any]:
    """A dict from a mapping (copied) or from a JSON file's path."""
    if isinstance(source, Mapping):
        doc = json.loads(json.dumps(source))  # a deep copy, and proof that it is JSON
        return cast(Dict[str, Any], doc)
    with open(source, encoding="utf-8") as f:
        doc = json.load(f)
    if not isinstance(doc, dict):
        raise ValueError(f"{source}: not a JSON object")
    return doc


def read_token_file(path: PathLike) -> str:
    """The first token of a token file (the daemon's format: blank and ``#`` lines ignored)."""
    with open(path, encoding="utf-8") as f:
        for line in f:
            line = line.strip()
            if line and not line.startswith("#"):
                return line
    raise ValueError(f"{path}: no token in the file")


def _retry_after(value: Optional[str]) -> Optional[float]:
    if value is None:
        return None
    try:
        return max(0.0, float(value))
    except ValueError:
        return None  # an HTTP date: fragsimd sends seconds only


class Client:
    """A fragsimd client.

    Args:
        base_url: the daemon, e.g. ``"http://127.0.0.1:8080"`` (a path prefix is kept, for a
            daemon behind a proxy under ``/fragsim/``).
        token: the bearer token. ``None``: the environment's ``FRAGSIM_TOKEN``, else the first
            token of the file ``token_file`` or of ``FRAGSIM_TOKEN_FILE``, else no token (for
            a daemon run with ``--no-auth``).
        token_file: a token file, as ``fragsim submit --token-file``.
        timeout: seconds for each request's connection and each read.
        retries: how many times a request answered 503 with ``Retry-After`` (``busy``,
            ``too_many_connections``) is sent again, after waiting as told (GET requests; other
            methods only for ``too_many_connections``, which the daemon refuses before reading).
        max_retry_wait: the longest wait for one ``Retry-After``, seconds.
    """

    def __init__(
        self,
        base_url: str = "http://127.0.0.1:8080",
        token: Optional[str] = None,
        *,
        token_file: Optional[PathLike] = None,
        timeout: float = 60.0,
        retries: int = 3,
        max_retry_wait: float = 30.0,
    ) -> None:
        self.base_url = base_url.rstrip("/")
        if token is None:
            token = os.environ.get("FRAGSIM_TOKEN") or None
        if token is None:
            tf = token_file or os.environ.get("FRAGSIM_TOKEN_FILE")
            if tf:
                token = read_token_file(tf)
        self.token = token
        self.timeout = timeout
        self.retries = retries
        self.max_retry_wait = max_retry_wait
        self._opener = urllib.request.build_opener()

    def __repr__(self) -> str:
        return f"Client({self.base_url!r}, token={'***' if self.token else None})"

    # ----------------------------------------------------------------------------------------
    # transport

    def _url(self, path: str, query: Optional[Mapping[str, Any]] = None) -> str:
        url = self.base_url + path
        if query:
            q = {k: _query_value(v) for k, v in query.items() if v is not None}
            if q:
                url += "?" + urllib.parse.urlencode(q)
        return url

    def _open(
        self,
        method: str,
        path: str,
        *,
        query: Optional[Mapping[str, Any]] = None,
        body: Optional[Any] = None,
        timeout: Optional[float] = None,
    ) -> Any:
        """Sends a request; returns the open response of a 2xx answer, raises otherwise."""
        url = self._url(path, query)
        data = None
        headers = {"Accept-Encoding": "gzip", "User-Agent": f"fragsim-python/{__version__}"}
        if self.token:
            headers["Authorization"] = f"Bearer {self.token}"
        if body is not None:
            data = json.dumps(body, allow_nan=False).encode("utf-8")
            headers["Content-Type"] = "application/json"
        attempt = 0
        while True:
            req = urllib.request.Request(url, data=data, headers=headers, method=method)
            try:
                return self._opener.open(req, timeout=timeout or self.timeout)
            except urllib.error.HTTPError as e:
                raw = e.read()
                if e.headers.get("Content-Encoding") == "gzip":
                    raw = gzip.decompress(raw)
                err = errors.from_response(
                    e.code,
                    raw,
                    method=method,
                    url=url,
                    retry_after=_retry_after(e.headers.get("Retry-After")),
                )
                if self._should_retry(err, method, attempt):
                    attempt += 1
                    time.sleep(min(err.retry_after or 0.0, self.max_retry_wait))
                    continue
                raise err from None
            except (urllib.error.URLError, OSError) as e:
                reason = getattr(e, "reason", e)
                raise errors.TransportError(f"{method} {url}: {reason}") from e

    def _should_retry(self, err: errors.ApiError, method: str, attempt: int) -> bool:
        if err.status != 503 or err.retry_after is None or attempt >= self.retries:
            return False
        return method == "GET" or err.code == "too_many_connections"

    @staticmethod
    def _read_all(resp: Any) -> bytes:
        try:
            with resp:
                raw: bytes = resp.read()
        except OSError as e:  # reset or timed out while the answer was read
            raise errors.TransportError(f"{resp.geturl()}: {e}") from e
        if resp.headers.get("Content-Encoding") == "gzip":
            raw = gzip.decompress(raw)
        return raw

    def _json(
        self,
        method: str,
        path: str,
        *,
        query: Optional[Mapping[str, Any]] = None,
        body: Optional[Any] = None,
    ) -> Any:
        raw = self._read_all(self._open(method, path, query=query, body=body))
        return json.loads(raw.decode("utf-8")) if raw else None

    def _obj(
        self,
        method: str,
        path: str,
        *,
        query: Optional[Mapping[str, Any]] = None,
        body: Optional[Any] = None,
    ) -> Dict[str, Any]:
        """A JSON answer that must be an object."""
        doc = self._json(method, path, query=query, body=body)
        if not isinstance(doc, dict):
            raise errors.FragsimError(f"{method} {path}: the answer is not a JSON object")
        return doc

    def _text(self, path: str, query: Optional[Mapping[str, Any]] = None) -> str:
        return self._read_all(self._open("GET", path, query=query)).decode("utf-8")

    def _download(
        self,
        path: str,
        dest: PathLike,
        *,
        query: Optional[Mapping[str, Any]] = None,
        timeout: Optional[float] = None,
    ) -> Path:
        """Streams a GET answer to ``dest`` (``dest.part`` first, renamed when complete)."""
        dest = Path(dest)
        part = dest.with_name(dest.name + ".part")
        resp = self._open("GET", path, query=query, timeout=timeout)
        try:
            with resp, open(part, "wb") as out:
                _copy_body(resp, out)
            os.replace(part, dest)
        except BaseException:
            part.unlink(missing_ok=True)
            raise
        return dest

    # ----------------------------------------------------------------------------------------
    # service

    def health(self) -> Dict[str, Any]:
        """``GET /v1/health`` (no token needed): status, version, git_sha, uptime_s, jobs."""
        return self._obj("GET", "/v1/health")

    def whoami(self) -> Dict[str, Any]:
        """``GET /v1/whoami``: this client's token as the daemon sees it: ``role`` (read, submit
        or admin), ``owner`` (the token's id, the owner of the jobs it submits) and ``auth``."""
        return self._obj("GET", "/v1/whoami")

    def openapi(self) -> str:
        """``GET /v1/openapi.yaml``: the daemon's HTTP contract (YAML text)."""
        return self._text("/v1/openapi.yaml")

    def api_version(self) -> str:
        """The contract version the daemon serves (``info.version`` of its openapi.yaml).

        Equal to :data:`fragsim.API_VERSION` when this client was written for that daemon.
        """
        return contract_version(self.openapi())

    def metrics(self) -> str:
        """``GET /metrics``: Prometheus text."""
        return self._text("/metrics")

    # ----------------------------------------------------------------------------------------
    # sites

    def upload_site(self, site: JsonSource) -> Dict[str, Any]:
        """``POST /v1/sites``: registers a site; returns its SiteSummary (``site_id``, ...).

        ``site`` is a site object, or a scenario (dict or file) whose inline ``site`` is sent.
        The id is a content hash: uploading the same site again returns the same summary.
        """
        doc = load_json(site)
        if "site" in doc and "terrain" not in doc:
            doc = doc["site"]
        return self._obj("POST", "/v1/sites", body=doc)

    def sites(self) -> List[Dict[str, Any]]:
        """``GET /v1/sites``: every registered site's SiteSummary, oldest first."""
        return list(self._obj("GET", "/v1/sites")["sites"])

    def site(self, site_id: str) -> Dict[str, Any]:
        """``GET /v1/sites/{id}``: one SiteSummary."""
        return self._obj("GET", f"/v1/sites/{_id(site_id)}")

    def delete_site(self, site_id: str) -> None:
        """``DELETE /v1/sites/{id}`` (409 :class:`~fragsim.errors.Conflict` while jobs use it)."""
        self._read_all(self._open("DELETE", f"/v1/sites/{_id(site_id)}"))

    def site_scene(self, site_id: str) -> Scene:
        """``GET /v1/sites/{id}/scene``: the site's terrain and buildings as numpy arrays."""
        return parse_scene(self._read_all(self._open("GET", f"/v1/sites/{_id(site_id)}/scene")))

    # ----------------------------------------------------------------------------------------
    # jobs

    def submit(
        self,
        scenario: JsonSource,
        *,
        site_id: Optional[str] = None,
        upload_site: bool = False,
        priority: Optional[int] = None,
        idempotency_key: Optional[str] = None,
    ) -> JobStatus:
        """``POST /v1/jobs``: queues a run; returns its JobStatus with ``warnings``.

        Args:
            scenario: a scenario (dict or JSON file, docs/scenario.md), with its site inline
                or a ``site_id``.
            site_id: run on this registered site (replaces the scenario's inline ``site``).
            upload_site: register the scenario's inline site first (``POST /v1/sites``) and
                submit with its id, as ``fragsim submit`` does: the site is built once and
                shared by later jobs. Otherwise an inline site is sent with the job and not
                registered (the job's ``site_id`` is then ``None``).
            priority: −1000 … 1000, higher first (daemon default 0).
            idempotency_key: makes a retried POST safe: the same key and body return the
                existing job (200), the same key with another body raises
                :class:`~fragsim.errors.Conflict` with ``field == "idempotency_key"``.
        """
        doc = load_json(scenario)
        if site_id is None and upload_site and "site" in doc:
            site_id = self.upload_site(doc["site"])["site_id"]
        if site_id is not None:
            doc.pop("site", None)
            doc["site_id"] = site_id
        if priority is not None:
            doc["priority"] = priority
        if idempotency_key is not None:
            doc["idempotency_key"] = idempotency_key
        return self._obj("POST", "/v1/jobs", body=doc)

    def jobs(self, state: Optional[str] = None, limit: Optional[int] = None) -> List[JobStatus]:
        """``GET /v1/jobs``: JobStatus of the jobs, newest first.

        ``state``: ``queued``, ``running``, ``done``, ``failed`` or ``cancelled``; ``limit``:
        1 … 1000. A bad value raises :class:`~fragsim.errors.BadRequest` naming the parameter.
        """
        return list(self._obj("GET", "/v1/jobs", query={"state": state, "limit": limit})["jobs"])

    def job(self, job_id: str) -> JobStatus:
        """``GET /v1/jobs/{id}``: state, progress (``histories_done``, ``progress``,
        ``histories_per_s``, ``eta_s``), ``error``, ``links``."""
        return self._obj("GET", f"/v1/jobs/{_id(job_id)}")

    status = job

    def cancel(self, job_id: str) -> JobStatus:
        """``DELETE /v1/jobs/{id}``: cancels a queued or running job; returns its JobStatus.

        A job already done, failed or cancelled raises :class:`~fragsim.errors.Conflict`.
        """
        return self._obj("DELETE", f"/v1/jobs/{_id(job_id)}")

    def purge(self, job_id: str) -> Dict[str, Any]:
        """``DELETE /v1/jobs/{id}?purge=true``: removes a finished (done, failed or cancelled)
        job, its row and every file of it; returns ``job_id``, ``purged``, ``state`` (the one
        it had) and ``bytes_freed``. The job is then unknown (:class:`~fragsim.errors.NotFound`).

        A queued or running job raises :class:`~fragsim.errors.Conflict` (cancel it first), as
        does the base job of a queued or running comparison. A job just cancelled whose run is
        still letting go of its files answers 409 with ``Retry-After``: waited out up to
        ``retries`` times.
        """
        attempt = 0
        while True:
            try:
                return self._obj("DELETE", f"/v1/jobs/{_id(job_id)}", query={"purge": "true"})
            except errors.Conflict as e:
                if e.retry_after is None or attempt >= self.retries:
                    raise
                attempt += 1
                time.sleep(min(e.retry_after, self.max_retry_wait))

    def retry(self, job_id: str) -> Dict[str, Any]:
        """``POST /v1/jobs/{id}/retry``: a failed job queued again under its id (e.g. one that
        failed with ``storage_full`` once space was freed); returns its JobStatus (``queued``).
        A job that is not failed, or failed with ``invalid_input``, raises
        :class:`~fragsim.errors.Conflict`; a short disk :class:`~fragsim.errors.StorageFull`.
        """
        return self._obj("POST", f"/v1/jobs/{_id(job_id)}/retry")

    def follow(
        self,
        job_id: str,
        *,
        poll_s: float = 0.1,
        max_poll_s: float = 2.0,
        timeout: Optional[float] = None,
    ) -> Iterator[JobStatus]:
        """Follows a job: yields its JobStatus each time its state or progress changes, the
        last one final (``done``, ``failed`` or ``cancelled``).

        Polls ``GET /v1/jobs/{id}`` every ``poll_s`` seconds at first; while nothing changes
        the interval grows by half each time up to ``max_poll_s`` (never beyond the job's
        ``eta_s`` while it runs), and drops back to ``poll_s`` when something changes. A 503
        with ``Retry-After`` is waited out (see ``retries``). ``timeout``: raise
        :class:`~fragsim.errors.WaitTimeout` after so many seconds.
        """
        deadline = None if timeout is None else time.monotonic() + timeout
        interval = poll_s
        last: Optional[Tuple[Any, ...]] = None
        while True:
            st = self.job(job_id)
            key = (st.get("state"), st.get("histories_done"), st.get("attempts"))
            if key != last:
                last = key
                interval = poll_s
                yield st
            else:
                interval = min(max_poll_s, interval * 1.5)
            if st.get("state") in FINAL_STATES:
                return
            wait = interval
            eta = st.get("eta_s")
            if isinstance(eta, (int, float)) and eta >= 0:
                wait = min(wait, max(poll_s, float(eta)))
            if deadline is not None:
                left = deadline - time.monotonic()
                if left <= 0:
                    raise errors.WaitTimeout(job_id, timeout or 0.0, st)
                wait = min(wait, left)
            time.sleep(wait)

    def wait(
        self,
        job_id: str,
        *,
        timeout: Optional[float] = None,
        callback: Optional[Callable[[JobStatus], None]] = None,
        raise_on_failure: bool = True,
        poll_s: float = 0.1,
        max_poll_s: float = 2.0,
    ) -> JobStatus:
        """Waits until the job is final and returns its last JobStatus.

        ``callback`` is called with every status :meth:`follow` yields (progress display).
        A job that ends ``failed`` or ``cancelled`` raises :class:`~fragsim.errors.JobFailed`
        unless ``raise_on_failure`` is false.
        """
        st: JobStatus = {}
        for st in self.follow(job_id, poll_s=poll_s, max_poll_s=max_poll_s, timeout=timeout):
            if callback is not None:
                callback(st)
        if raise_on_failure and st.get("state") != "done":
            raise errors.JobFailed(st)
        return st

    # ----------------------------------------------------------------------------------------
    # results of a done job (409 NotReady otherwise)

    def summary(self, job_id: str) -> Dict[str, Any]:
        """``GET /v1/jobs/{id}/summary``: the job's summary.json (docs/scenario.md)."""
        return self._obj("GET", f"/v1/jobs/{_id(job_id)}/summary")

    def buildings(self, job_id: str) -> List[Dict[str, Any]]:
        """``GET /v1/jobs/{id}/buildings``: per building ``id``, ``expected_impacts``,
        ``impacts_std_error``, ``expected_penetrations``, ``penetrations_std_error``."""
        return list(self._obj("GET", f"/v1/jobs/{_id(job_id)}/buildings")["buildings"])

    def ptn(self, job_id: str) -> Dict[str, Any]:
        """``GET /v1/jobs/{id}/ptn``: ``density_per_m2`` and ``std_error_per_m2`` as float64
        numpy arrays (one value per terrain triangle), ``threshold_per_m2``, ``triangles``."""
        doc = self._obj("GET", f"/v1/jobs/{_id(job_id)}/ptn")
        for k in ("density_per_m2", "std_error_per_m2"):
            doc[k] = np.asarray(doc[k], dtype=np.float64)
        return doc

    def download_ptn_geojson(
        self, job_id: str, dest: PathLike, *, min_density_per_m2: Optional[float] = None
    ) -> Path:
        """``GET /v1/jobs/{id}/ptn?format=geojson``: one polygon per terrain triangle (only
        those with density ≥ ``min_density_per_m2`` when given) saved to ``dest``."""
        q = {"format": "geojson", "min_density_per_m2": min_density_per_m2}
        return self._download(f"/v1/jobs/{_id(job_id)}/ptn", dest, query=q)

    def plan_boundary(self, job_id: str, *, smoothing_m: Optional[float] = None) -> Dict[str, Any]:
        """``GET /v1/jobs/{id}/plan_boundary``: the site-plan boundary (sector envelope and
        smoothed contour, input coordinates in metres; docs/gis.md)."""
        q = {"smoothing_m": smoothing_m}
        return self._obj("GET", f"/v1/jobs/{_id(job_id)}/plan_boundary", query=q)

    def download_results(self, job_id: str, dest: PathLike) -> Path:
        """``GET /v1/jobs/{id}/results.h5`` saved to ``dest``; read it with
        :func:`fragsim.results.open`."""
        return self._download(f"/v1/jobs/{_id(job_id)}/results.h5", dest)

    def download_summary(self, job_id: str, dest: PathLike) -> Path:
        """The job's summary.json saved to ``dest`` (the bytes the daemon stored)."""
        return self._download(f"/v1/jobs/{_id(job_id)}/summary", dest)

    def maps(self, job_id: str) -> Dict[str, Any]:
        """``GET /v1/jobs/{id}/maps``: the GIS files' listing (``crs``, ``files`` with
        ``name``, ``content_type``, ``bytes``; ``notes``). The first call makes them."""
        return self._obj("GET", f"/v1/jobs/{_id(job_id)}/maps")

    def download_map(self, job_id: str, name: str, dest: PathLike) -> Path:
        """``GET /v1/jobs/{id}/maps/{name}`` saved to ``dest`` (a name not in the listing
        raises :class:`~fragsim.errors.NotFound`)."""
        quoted = urllib.parse.quote(name, safe="")
        return self._download(f"/v1/jobs/{_id(job_id)}/maps/{quoted}", dest)

    def download_maps(
        self, job_id: str, directory: PathLike, names: Optional[Sequence[str]] = None
    ) -> List[Path]:
        """Every map file (or those of ``names``) saved into ``directory`` (made if needed)."""
        d = Path(directory)
        d.mkdir(parents=True, exist_ok=True)
        if names is None:
            names = [f["name"] for f in self.maps(job_id)["files"]]
        return [self.download_map(job_id, n, d / n) for n in names]

    def hazardous_area(self, job_id: str, *, layer: str = "hazardous_area") -> Any:
        """The job's hazardous area as a geopandas GeoDataFrame (optional extra ``gis``).

        Reads ``layer`` of the job's ``hazard.gpkg`` (in the site's CRS, or local metres for a
        site without one): ``hazardous_area`` (features ``estimate``, ``lower_1se``,
        ``upper_1se``), or ``hazard_boundary``, ``hfd_envelope``, ``hfd``, ``hfd_sectors``,
        ``buildings`` (docs/gis.md, "Outputs").
        """
        try:
            import geopandas
        except ImportError as e:
            raise ImportError(
                "hazardous_area() needs geopandas: pip install 'fragsim[gis]' "
                "(Debian: apt-get install python3-geopandas)"
            ) from e
        import tempfile

        with tempfile.TemporaryDirectory(prefix="fragsim-") as tmp:
            path = self.download_map(job_id, "hazard.gpkg", Path(tmp) / "hazard.gpkg")
            return geopandas.read_file(path, layer=layer)

    def report_html(
        self, job_id: str, dest: Optional[PathLike] = None, *, units: str = "si"
    ) -> Any:
        """``GET /v1/jobs/{id}/report.html?units=si|us``: the study report (docs/report.md).

        Returns the page's text, or with ``dest`` the path it was saved to.
        """
        path = f"/v1/jobs/{_id(job_id)}/report.html"
        if dest is not None:
            q = {"units": units}
            return self._download(path, dest, query=q, timeout=max(self.timeout, 120))
        return self._text(path, {"units": units})

    def download_report_pdf(self, job_id: str, dest: PathLike, *, units: str = "si") -> Path:
        """``GET /v1/jobs/{id}/report.pdf?units=si|us`` saved to ``dest``. A daemon without
        chromium raises :class:`~fragsim.errors.ServiceUnavailable` (``pdf_unavailable``);
        ``busy`` is retried after its ``Retry-After``."""
        path = f"/v1/jobs/{_id(job_id)}/report.pdf"
        return self._download(path, dest, query={"units": units}, timeout=max(self.timeout, 120))

    def job_scene(self, job_id: str, *, max_trajectories: Optional[int] = None) -> Scene:
        """``GET /v1/jobs/{id}/scene``: terrain, PTN density (float32), buildings and a sample
        of the recorded trajectories, as numpy arrays (what the web viewer draws)."""
        q = {"max_trajectories": max_trajectories}
        resp = self._open("GET", f"/v1/jobs/{_id(job_id)}/scene", query=q)
        return parse_scene(self._read_all(resp))

    # ----------------------------------------------------------------------------------------
    # compare: paired what-if runs (docs/comparison.md)

    def compare(
        self, base_job_id: str, variant: JsonSource, **submit_args: Any
    ) -> JobStatus:
        """Submits ``variant`` as the variant of a paired comparison with the job
        ``base_job_id`` (``compare_with``): the base job's histories are flown again over the
        variant's site, so each difference comes with a paired standard error. The variant
        may change the site and atmosphere, not the fragment groups or settings; what cannot
        be paired raises :class:`~fragsim.errors.Unprocessable` naming the field. Other
        arguments as :meth:`submit`. The job's results are the variant's; its comparison is
        :meth:`comparison`."""
        doc = load_json(variant)
        doc["compare_with"] = _id(base_job_id)
        return self.submit(doc, **submit_args)

    def comparison(self, job_id: str) -> Dict[str, Any]:
        """``GET /v1/jobs/{id}/compare``: compare.json of a job submitted with
        ``compare_with`` (``hfd``, ``buildings``, ``outcomes``, ``density``, each figure with
        ``base``, ``variant``, ``difference``, ``paired_std_error`` and
        ``unpaired_std_error``; ``limitations``). A job without one raises
        :class:`~fragsim.errors.NotFound`."""
        return self._obj("GET", f"/v1/jobs/{_id(job_id)}/compare")

    def comparison_buildings(self, job_id: str) -> Any:
        """The comparison's building figures as a pandas DataFrame (one row per building of
        either site; columns ``impacts_base``, ``impacts_difference``,
        ``impacts_paired_std_error``, ... and the same for penetrations)."""
        import pandas

        rows = []
        for b in self.comparison(job_id)["buildings"]:
            row: Dict[str, Any] = {"id": b["id"], "in_base": b["in_base"],
                                   "in_variant": b["in_variant"]}
            for figure in ("impacts", "penetrations"):
                for key, value in b[figure].items():
                    row[f"{figure}_{key}"] = value
            rows.append(row)
        return pandas.DataFrame(rows).set_index("id")

    def download_comparison_h5(self, job_id: str, dest: PathLike) -> Path:
        """``GET /v1/jobs/{id}/compare.h5`` saved to ``dest``: the density difference per
        terrain triangle and its paired se (when both sites share the terrain)."""
        return self._download(f"/v1/jobs/{_id(job_id)}/compare.h5", dest)

    # ----------------------------------------------------------------------------------------

    def run(
        self,
        scenario: JsonSource,
        *,
        results: Optional[PathLike] = None,
        timeout: Optional[float] = None,
        callback: Optional[Callable[[JobStatus], None]] = None,
        **submit_args: Any,
    ) -> Dict[str, Any]:
        """Submits, waits and returns the summary (and downloads results.h5 to ``results``):
        ``fragsim submit --out`` in one call. Raises :class:`~fragsim.errors.JobFailed`."""
        job = self.submit(scenario, **submit_args)
        self.wait(job["job_id"], timeout=timeout, callback=callback)
        if results is not None:
            self.download_results(job["job_id"], results)
        return self.summary(job["job_id"])


# "info:" at the start of a line, then its indented lines up to the first "version:".
_CONTRACT_VERSION = re.compile(
    r"^info:\s*\n(?:[ \t]+.*\n)*?[ \t]+version:\s*['\"]?([^'\"\s]+)", re.M
)


def contract_version(openapi_yaml: str) -> str:
    """``info.version`` of an OpenAPI document's text (without a YAML library)."""
    m = _CONTRACT_VERSION.search(openapi_yaml)
    if not m:
        raise ValueError("no info.version in the OpenAPI document")
    return m.group(1)


def _id(value: str) -> str:
    return urllib.parse.quote(str(value), safe="")


def _query_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return repr(v)
    return str(v)


def _copy_body(resp: Any, out: IO[bytes]) -> None:
    gz = resp.headers.get("Content-Encoding") == "gzip"
    dec = zlib.decompressobj(16 + zlib.MAX_WBITS) if gz else None
    while True:
        chunk = resp.read(1 << 20)
        if not chunk:
            break
        out.write(dec.decompress(chunk) if dec else chunk)
    if dec:
        out.write(dec.flush())


__all__ = [
    "API_VERSION",
    "Client",
    "FINAL_STATES",
    "JobStatus",
    "contract_version",
    "load_json",
    "read_token_file",
]
