"""fragsim: client of the fragsimd HTTP API and reader of results.h5 (docs/python.md).

- :class:`Client`: sites, jobs (submit, list, follow, wait, cancel) and results (summary,
  buildings, PTN, plan boundary, results.h5, maps, report, scene) of a fragsimd daemon; the
  standard library's urllib only.
- :mod:`fragsim.results`: ``fragsim.results.open(path)`` reads a results.h5 (h5py) into numpy
  arrays and pandas DataFrames.
- :mod:`fragsim.errors`: the exceptions (``FragsimError`` and its subclasses).

The package version is the HTTP contract version it speaks (:data:`API_VERSION`,
``info.version`` of api/openapi.yaml).
"""

from . import errors, results
from ._version import API_VERSION, __version__
from .client import FINAL_STATES, Client, JobStatus, contract_version, load_json
from .errors import (
    ApiError,
    BadRequest,
    Conflict,
    FragsimError,
    Forbidden,
    JobFailed,
    LimitExceeded,
    MethodNotAllowed,
    NotFound,
    NotReady,
    PayloadTooLarge,
    ServerError,
    ServiceUnavailable,
    StorageFull,
    TransportError,
    Unauthorized,
    Unprocessable,
    UnsupportedFormat,
    UnsupportedMediaType,
    WaitTimeout,
)
from .scene import Scene, parse_scene

__all__ = [
    "API_VERSION",
    "ApiError",
    "BadRequest",
    "Client",
    "Conflict",
    "FINAL_STATES",
    "FragsimError",
    "Forbidden",
    "JobFailed",
    "JobStatus",
    "LimitExceeded",
    "MethodNotAllowed",
    "NotFound",
    "NotReady",
    "PayloadTooLarge",
    "Scene",
    "ServerError",
    "ServiceUnavailable",
    "StorageFull",
    "TransportError",
    "Unauthorized",
    "Unprocessable",
    "UnsupportedFormat",
    "UnsupportedMediaType",
    "WaitTimeout",
    "__version__",
    "contract_version",
    "errors",
    "load_json",
    "parse_scene",
    "results",
]
