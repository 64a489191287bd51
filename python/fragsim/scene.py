"""The scene format of ``GET /v1/sites/{id}/scene`` and ``GET /v1/jobs/{id}/scene``.

Little-endian: ASCII ``FSSCENE1``, uint32 H, H bytes of JSON header, then the data block; each
array of the header's ``arrays`` lies at ``12 + H + offset`` (docs/http-api.md, "The scene
format"). Positions are float32 relative to the header's ``offset_m``.
"""

from __future__ import annotations

import json
import struct
from dataclasses import dataclass, field
from typing import Any, Dict

import numpy as np
import numpy.typing as npt

from .errors import UnsupportedFormat

MAGIC = b"FSSCENE1"
_TYPES = {"f32": "<f4", "u32": "<u4", "u16": "<u2", "u8": "u1"}


@dataclass
class Scene:
    """A parsed scene.

    Attributes:
        header: the JSON header (``format``, ``offset_m``, ``building_ids``, ``material_names``,
            ``trajectories``, ...).
        arrays: name → numpy array (``terrain_vertices`` [n, 3] float32, ``terrain_triangles``
            [m, 3] uint32, ``density_per_m2`` [m] float32 for a job, ...). Arrays of an unknown
            type are left out.
    """

    header: Dict[str, Any]
    arrays: Dict[str, npt.NDArray[Any]] = field(default_factory=dict)

    @property
    def offset_m(self) -> npt.NDArray[Any]:
        """Input coordinate = position + offset_m."""
        return np.asarray(self.header.get("offset_m", [0.0, 0.0, 0.0]), dtype=np.float64)

    def __getitem__(self, name: str) -> npt.NDArray[Any]:
        return self.arrays[name]


def parse_scene(data: bytes) -> Scene:
    """Parses a scene's bytes (arrays are copied out of ``data``)."""
    if len(data) < 12 or data[:8] != MAGIC:
        raise UnsupportedFormat("not a fragsim scene (no FSSCENE1 magic)")
    (h,) = struct.unpack_from("<I", data, 8)
    if 12 + h > len(data):
        raise UnsupportedFormat("scene header runs past the end of the data")
    header = json.loads(data[12 : 12 + h].decode("utf-8"))
    base = 12 + h
    arrays: Dict[str, npt.NDArray[Any]] = {}
    for name, spec in header.get("arrays", {}).items():
        dtype = _TYPES.get(spec.get("type"))
        if dtype is None:
            continue
        start = base + int(spec["offset"])
        nbytes = int(spec["bytes"])
        if start + nbytes > len(data):
            raise UnsupportedFormat(f"scene array {name} runs past the end of the data")
        a = np.frombuffer(data, dtype=dtype, count=nbytes // np.dtype(dtype).itemsize, offset=start)
        arrays[name] = a.reshape(spec["shape"]).astype(np.dtype(dtype).newbyteorder("="))
    return Scene(header, arrays)
