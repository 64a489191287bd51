"""Reader of fragsim's ``results.h5`` (needs h5py; the DataFrames need pandas).

The layout is docs/scenario.md, "results.h5" (written by formats/results_h5.cpp). The root attributes
``file_type`` (``"fragsim.results"``) and ``format_version`` say what the file is; this reader
knows formats 1 … 5 (:data:`SUPPORTED_FORMATS`) and refuses anything else with
:class:`~fragsim.errors.UnsupportedFormat` naming the file and the version. What an older format
lacks reads as ``None`` (e.g. ``summary`` before format 5, ``material`` before 4).

Example::

    import fragsim
    with fragsim.results.open("results.h5") as r:
        print(r.hfd.distance_m, r.hfd.bound)
        dens, se = r.density_per_m2, r.std_error_per_m2     # one value per terrain triangle
        xy = r.centroids_m[:, :2]
        df = r.buildings()                                  # pandas DataFrame, one row per building
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from functools import cached_property
from typing import TYPE_CHECKING, Any, Dict, List, Optional, Union

import numpy as np
import numpy.typing as npt

from .errors import UnsupportedFormat

if TYPE_CHECKING:  # pragma: no cover
    import pandas

FILE_TYPE = "fragsim.results"
#: The results.h5 format versions this reader knows (formats/results_h5.h kResultsFormatVersion).
SUPPORTED_FORMATS = (1, 2, 3, 4, 5)
#: Columns of the ``*_by_surface`` datasets (attribute ``columns``).
SURFACES = ("terrain", "wall", "roof", "window")

PathLike = Union[str, "os.PathLike[str]"]
Array = npt.NDArray[Any]


def _h5py() -> Any:
    try:
        import h5py
    except ImportError as e:
        raise ImportError(
            "fragsim.results needs h5py: pip install 'fragsim[h5]' "
            "(Debian: apt-get install python3-h5py)"
        ) from e
    return h5py


def _pandas() -> Any:
    try:
        import pandas
    except ImportError as e:
        raise ImportError(
            "DataFrames need pandas: pip install 'fragsim[pandas]' "
            "(Debian: apt-get install python3-pandas)"
        ) from e
    return pandas


def _text(value: Any) -> str:
    """An HDF5 string (fixed-length, null-padded UTF-8) as str."""
    if isinstance(value, (bytes, np.bytes_)):
        return bytes(value).rstrip(b"\0").decode("utf-8")
    return str(value)


def _strings(a: Array) -> List[str]:
    return [_text(v) for v in a]


def _bound(flag: Any) -> str:
    return "lower" if int(flag) else "none"


@dataclass(frozen=True)
class Hfd:
    """The hazardous fragment distance figures of ``/hfd`` (docs/scenario.md, summary.json).

    ``bound`` is ``"lower"`` when the site boundary cuts the HFD (the figure is then a lower
    bound), else ``"none"``; ``band_bound`` and ``by_sector_bound`` likewise per value. The
    site-boundary figures are ``None`` in format 1 files.
    """

    distance_m: float
    band_m: Array  # [lower, upper]
    by_sector_m: Array  # 36: sector k is azimuth [10k, 10k+10) deg from +x toward +y
    origin_m: Array  # (3,)
    threshold_per_m2: float
    bound: Optional[str]
    band_bound: Optional[List[str]]
    by_sector_bound: Optional[List[str]]
    note: Optional[str]
    boundary_max_density_per_m2: Optional[float]
    left_site_hazardous_fragments: Optional[float]
    left_site_hazardous_fragments_std_error: Optional[float]


class Results:
    """An open results.h5. Use :func:`open`; close with :meth:`close` or a ``with`` block.

    Arrays are read on first use and kept (numpy, the file's dtypes: float64 figures, uint32
    indices). :attr:`file` is the h5py.File for anything not wrapped here.
    """

    def __init__(self, path: PathLike) -> None:
        h5py = _h5py()
        self.path = os.fspath(path)
        try:
            self.file = h5py.File(self.path, "r")
        except OSError as e:
            raise UnsupportedFormat(f"{self.path}: not an HDF5 file ({e})") from e
        try:
            self._check_format()
        except BaseException:
            self.file.close()
            raise

    def _check_format(self) -> None:
        attrs = self.file.attrs
        file_type = _text(attrs["file_type"]) if "file_type" in attrs else None
        if file_type != FILE_TYPE:
            raise UnsupportedFormat(
                f"{self.path}: not a fragsim results file (root attribute file_type is "
                f"{file_type!r}, expected {FILE_TYPE!r})"
            )
        version = int(attrs["format_version"]) if "format_version" in attrs else None
        if version not in SUPPORTED_FORMATS:
            raise UnsupportedFormat(
                f"{self.path}: results.h5 format_version {version}; this reader "
                f"(fragsim {_package_version()}) knows {SUPPORTED_FORMATS[0]}…"
                f"{SUPPORTED_FORMATS[-1]}: use a fragsim package as new as the file's writer "
                f"(fragsim_version {_text(attrs.get('fragsim_version', b'?'))})"
            )
        self.format_version: int = version

    # -- life cycle ---------------------------------------------------------------------------

    def close(self) -> None:
        """Closes the file (arrays already read stay usable)."""
        self.file.close()

    def __enter__(self) -> "Results":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"<fragsim.results.Results {self.path!r} format {self.format_version}>"

    def _array(self, name: str) -> Optional[Array]:
        return self.file[name][()] if name in self.file else None

    def _need(self, name: str) -> Array:
        if name not in self.file:
            raise UnsupportedFormat(f"{self.path}: no dataset {name}")
        return np.asarray(self.file[name][()])

    # -- root attributes ----------------------------------------------------------------------

    @cached_property
    def attrs(self) -> Dict[str, Any]:
        """Root attributes, strings decoded, numbers as Python numbers (``seed``, ``samples``,
        ``histories_done``, ``stop_reason``, ``fragsim_version``, ``git_sha``, ``wall_s``, ...)."""
        out: Dict[str, Any] = {}
        for k, v in self.file.attrs.items():
            out[k] = _text(v) if isinstance(v, (bytes, np.bytes_, str)) else v.item()
        return out

    @cached_property
    def scenario(self) -> Dict[str, Any]:
        """The normalised scenario the run used (every default filled in)."""
        doc: Dict[str, Any] = json.loads(self.attrs["scenario_json"])
        return doc

    @cached_property
    def summary(self) -> Optional[Dict[str, Any]]:
        """summary.json's content (format 5 on; ``None`` before)."""
        s = self.attrs.get("summary_json")
        return json.loads(s) if s else None

    # -- terrain and PTN ----------------------------------------------------------------------

    @cached_property
    def vertices_m(self) -> Array:
        """Terrain vertices (n × 3, float64, input coordinates)."""
        return self._need("terrain/vertices_m")

    @cached_property
    def triangles(self) -> Array:
        """Terrain triangles (m × 3 uint32 vertex indices); the PTN bins, in this order."""
        return self._need("terrain/triangles")

    @cached_property
    def triangle_vertices_m(self) -> Array:
        """Each terrain triangle's three corners (m × 3 × 3, input coordinates)."""
        return self.vertices_m[self.triangles]

    @cached_property
    def centroids_m(self) -> Array:
        """Terrain triangle centroids (m × 3, input coordinates: the points the HFD is measured
        to)."""
        return np.asarray(self.triangle_vertices_m.mean(axis=1))

    @cached_property
    def area_m2(self) -> Array:
        """Terrain triangle areas (m)."""
        return self._need("terrain/area_m2")

    @cached_property
    def material(self) -> Optional[Array]:
        """Each terrain triangle's material index into :attr:`material_names` (format 4 on)."""
        return self._array("terrain/material")

    @cached_property
    def material_names(self) -> Optional[List[str]]:
        """The site's materials in index order (format 4 on)."""
        a = self._array("terrain/material_names")
        return None if a is None else _strings(a)

    @cached_property
    def density_per_m2(self) -> Array:
        """PTN hazardous fragment density per terrain triangle, per m² (m, float64)."""
        return self._need("ptn/density_per_m2")

    @cached_property
    def std_error_per_m2(self) -> Array:
        """Standard error of :attr:`density_per_m2` (m, float64)."""
        return self._need("ptn/std_error_per_m2")

    @cached_property
    def hazardous(self) -> Array:
        """Boolean mask of the terrain triangles with density ≥ the HFD threshold."""
        return self.density_per_m2 >= self.hfd.threshold_per_m2

    # -- HFD ----------------------------------------------------------------------------------

    @cached_property
    def hfd(self) -> Hfd:
        """The HFD figures (:class:`Hfd`)."""
        g = self.file["hfd"]

        def opt(name: str) -> Optional[Any]:
            return g[name][()] if name in g else None

        bound = opt("bound")
        band_bound = opt("band_bound")
        sector_bound = opt("by_sector_bound")
        bmax, left, left_se = (
            opt("boundary_max_density_per_m2"),
            opt("left_site_hazardous_fragments"),
            opt("left_site_hazardous_fragments_std_error"),
        )
        return Hfd(
            distance_m=float(g["hazardous_fragment_distance_m"][()]),
            band_m=g["band_m"][()],
            by_sector_m=g["by_sector_m"][()],
            origin_m=g["origin_m"][()],
            threshold_per_m2=float(g["threshold_per_m2"][()]),
            bound=None if bound is None else _bound(bound),
            band_bound=None if band_bound is None else [_bound(b) for b in band_bound],
            by_sector_bound=None if sector_bound is None else [_bound(b) for b in sector_bound],
            note=_text(g.attrs["note"]) if "note" in g.attrs else None,
            boundary_max_density_per_m2=None if bmax is None else float(bmax),
            left_site_hazardous_fragments=None if left is None else float(left),
            left_site_hazardous_fragments_std_error=None if left_se is None else float(left_se),
        )

    # -- buildings, outcomes, fragments, trajectories -----------------------------------------

    @cached_property
    def building_ids(self) -> List[str]:
        """Building ids in scenario order (empty for a site without buildings)."""
        a = self._array("buildings/id")
        return [] if a is None else _strings(a)

    def building_arrays(self) -> Dict[str, Array]:
        """Per-building columns as numpy arrays (what :meth:`buildings` puts in a DataFrame).

        ``id``; ``expected_impacts``, ``impacts_std_error``, ``expected_penetrations``,
        ``penetrations_std_error``, ``residual_ke_j``, ``residual_ke_std_error_j``; and for each
        surface S of wall, roof, window: ``impacts_S``, ``impacts_S_std_error``,
        ``penetrations_S``, ``penetrations_S_std_error``, ``area_S_m2``.
        """
        g = self.file["buildings"] if "buildings" in self.file else None
        cols: Dict[str, Array] = {"id": np.array(self.building_ids, dtype=object)}
        n = len(self.building_ids)
        for name in (
            "expected_impacts",
            "impacts_std_error",
            "expected_penetrations",
            "penetrations_std_error",
            "residual_ke_j",
            "residual_ke_std_error_j",
        ):
            cols[name] = g[name][()] if g is not None and name in g else np.zeros(n)
        by_surface = {
            "impacts_{}": "impacts_by_surface",
            "impacts_{}_std_error": "impacts_by_surface_std_error",
            "penetrations_{}": "penetrations_by_surface",
            "penetrations_{}_std_error": "penetrations_by_surface_std_error",
            "area_{}_m2": "surface_area_m2",
        }
        for pattern, dataset in by_surface.items():
            if g is None or dataset not in g:
                continue
            table = g[dataset][()]
            for j, surface in enumerate(SURFACES):
                if surface != "terrain":
                    cols[pattern.format(surface)] = table[:, j]
        return cols

    def buildings(self) -> "pandas.DataFrame":
        """The buildings as a pandas DataFrame, one row per building in scenario order, columns
        as :meth:`building_arrays` (expected numbers of real fragments and their standard
        errors)."""
        pd = _pandas()
        return pd.DataFrame(self.building_arrays())

    def outcomes(self) -> "pandas.DataFrame":
        """How the histories ended: ``name``, ``histories``, ``fragments``,
        ``fragments_std_error`` (pandas)."""
        pd = _pandas()
        g = self.file["outcomes"]
        return pd.DataFrame(
            {
                "name": _strings(g["name"][()]),
                "histories": g["histories"][()],
                "fragments": g["fragments"][()],
                "fragments_std_error": g["fragments_std_error"][()],
            }
        )

    @property
    def has_fragments(self) -> bool:
        """Whether the run recorded its fragments (``settings.record_fragments``)."""
        return "fragments" in self.file

    def fragment_arrays(self) -> Optional[Dict[str, Array]]:
        """``/fragments`` (one row per history), dataset name → array; ``None`` when not
        recorded. Vector fields are n × 3."""
        if not self.has_fragments:
            return None
        g = self.file["fragments"]
        first = [k for k in ("group", "history") if k in g]
        return {k: g[k][()] for k in first + [k for k in g.keys() if k not in first]}

    def fragments(self) -> Optional["pandas.DataFrame"]:
        """The recorded fragments as a pandas DataFrame (``None`` when not recorded): a column
        per scalar field, ``_x``/``_y``/``_z`` columns per vector field, and ``outcome_name``
        beside the ``outcome`` index."""
        arrays = self.fragment_arrays()
        if arrays is None:
            return None
        pd = _pandas()
        cols: Dict[str, Any] = {}
        for k, a in arrays.items():
            if a.ndim == 2 and a.shape[1] == 3:
                for j, axis in enumerate("xyz"):
                    cols[f"{k}_{axis}"] = a[:, j]
            else:
                cols[k] = a
        df = pd.DataFrame(cols)
        names_attr = self.file["fragments/outcome"].attrs.get("names")
        if names_attr is not None and "outcome" in df:
            names = _text(names_attr).split(",")
            df["outcome_name"] = [names[i] if i < len(names) else str(i) for i in df["outcome"]]
        return df

    def trajectories(self) -> Optional[Dict[str, Array]]:
        """``/trajectories`` (``settings.record_trajectories``) as arrays, or ``None``: points
        of trajectory i are rows ``offsets[i]`` … ``offsets[i+1] − 1`` of ``t_s``,
        ``position_m``, ``velocity_mps``, ``event``."""
        if "trajectories" not in self.file:
            return None
        g = self.file["trajectories"]
        return {k: g[k][()] for k in g.keys()}

    def datasets(self) -> Dict[str, Array]:
        """Every dataset of the file by its path (for comparisons and export)."""
        h5py = _h5py()
        out: Dict[str, Array] = {}

        def visit(name: str, obj: Any) -> None:
            if isinstance(obj, h5py.Dataset):
                out[name] = obj[()]

        self.file.visititems(visit)
        return out


def open(path: PathLike) -> Results:  # noqa: A001 (the module's entry point: results.open)
    """Opens a results.h5 for reading; raises :class:`~fragsim.errors.UnsupportedFormat` for a
    file that is not one or is of an unknown format version."""
    return Results(path)


def _package_version() -> str:
    from ._version import __version__

    return __version__


__all__ = ["FILE_TYPE", "Hfd", "Results", "SUPPORTED_FORMATS", "SURFACES", "open"]
