"""Exceptions of the fragsim client.

Every error response of fragsimd (4xx, 5xx) has the JSON body ``{"code", "message", "field"}``
(docs/http-api.md, "Errors"); :class:`ApiError` carries the three plus the HTTP status, and its
subclass is chosen by the status (and for some by the code)::

    FragsimError
    ├── ApiError                   any 4xx/5xx answer: .status .code .message .field
    │   ├── BadRequest             400 (malformed_json, too_deep, bad_parameter, bad_request)
    │   ├── Unauthorized           401
    │   ├── Forbidden              403 (the token's role may not do this)
    │   ├── NotFound               404
    │   ├── MethodNotAllowed       405
    │   ├── RequestTimeout         408
    │   ├── Conflict               409
    │   │   └── NotReady           409 not_ready (results of a job that is not done)
    │   ├── LengthRequired         411
    │   ├── PayloadTooLarge        413
    │   ├── UnsupportedMediaType   415
    │   ├── Unprocessable          422 (invalid_input: .field is the path of the bad value)
    │   │   └── LimitExceeded      422 limit_exceeded
    │   ├── HeadersTooLarge        431
    │   ├── ServerError            500 and any other 5xx
    │   │   └── StorageFull        507 storage_full (the data directory's disk is short)
    │   └── ServiceUnavailable     503 (busy, pdf_unavailable, too_many_connections)
    ├── TransportError             no HTTP answer (connection refused, reset, timed out)
    ├── JobFailed                  wait(): the job ended failed or cancelled
    ├── WaitTimeout                wait()/follow(): the time given ran out
    └── UnsupportedFormat          results.open(): not a results.h5 this reader knows
"""

from __future__ import annotations

import json
from typing import Any, Dict, Mapping, Optional, Type


class FragsimError(Exception):
    """Base class of every error the fragsim package raises."""


class ApiError(FragsimError):
    """fragsimd answered with an error status.

    Attributes:
        status: the HTTP status (e.g. 422).
        code: the error body's ``code`` (e.g. ``"invalid_input"``); ``"http_<status>"`` when the
            body was not fragsimd's JSON (a proxy's page).
        message: the error body's ``message``.
        field: the error body's ``field``: the JSON path of the offending value in the request
            body (``"fragment_groups[0].mass_kg.sigma_ln"``, ``"site_id"``), or the name of the
            offending query parameter (``"state"``), or ``None``.
        method, url: the request.
        retry_after: seconds from a ``Retry-After`` header, or ``None``.
        body: the raw response body.
    """

    def __init__(
        self,
        status: int,
        code: str,
        message: str,
        field: Optional[str] = None,
        *,
        method: str = "",
        url: str = "",
        retry_after: Optional[float] = None,
        body: bytes = b"",
    ) -> None:
        self.status = status
        self.code = code
        self.message = message
        self.field = field
        self.method = method
        self.url = url
        self.retry_after = retry_after
        self.body = body
        where = f" (field {field})" if field else ""
        super().__init__(f"{status} {code}: {message}{where} [{method} {url}]")


class BadRequest(ApiError):
    """400: unreadable JSON, a bad query parameter (``field`` names it)."""


class Unauthorized(ApiError):
    """401: missing or wrong bearer token."""


class Forbidden(ApiError):
    """403 ``forbidden``: the token's role (read, submit, admin) may not do this
    (docs/operations.md, "Roles"); the message says what is needed."""


class NotFound(ApiError):
    """404: unknown route, site or job."""


class MethodNotAllowed(ApiError):
    """405."""


class RequestTimeout(ApiError):
    """408: the request did not arrive in time."""


class Conflict(ApiError):
    """409: a site in use, a job already final, an idempotency key reused with another body."""


class NotReady(Conflict):
    """409 ``not_ready``: results of a job that is not done."""


class LengthRequired(ApiError):
    """411."""


class PayloadTooLarge(ApiError):
    """413: body above the daemon's ``--max-body-bytes``."""


class UnsupportedMediaType(ApiError):
    """415."""


class Unprocessable(ApiError):
    """422: valid JSON that breaks the contract; ``field`` is the path of the value."""


class LimitExceeded(Unprocessable):
    """422 ``limit_exceeded``: too many samples, sites or queued jobs."""


class HeadersTooLarge(ApiError):
    """431."""


class ServerError(ApiError):
    """500 (``internal``) and any 5xx other than 503."""


class StorageFull(ServerError):
    """507 ``storage_full``: the daemon's disk is short of space (docs/operations.md); new jobs
    are refused until space is freed, queued ones wait."""


class ServiceUnavailable(ApiError):
    """503: ``busy`` (retry after ``retry_after``), ``pdf_unavailable``,
    ``too_many_connections``."""


class TransportError(FragsimError):
    """No HTTP answer: connection refused or reset, DNS, time-out."""


class JobFailed(FragsimError):
    """A job waited for ended ``failed`` or ``cancelled``; ``status`` is its last JobStatus."""

    def __init__(self, status: Mapping[str, Any]) -> None:
        self.status: Dict[str, Any] = dict(status)
        err = self.status.get("error") or {}
        why = f": {err.get('code')}: {err.get('message')}" if err else ""
        super().__init__(f"job {self.status.get('job_id')} {self.status.get('state')}{why}")


class WaitTimeout(FragsimError):
    """The time given to ``wait``/``follow`` ran out; ``status`` is the last JobStatus seen."""

    def __init__(self, job_id: str, timeout: float, status: Mapping[str, Any]) -> None:
        self.status: Dict[str, Any] = dict(status)
        super().__init__(
            f"job {job_id} not finished after {timeout:g} s (state {self.status.get('state')})"
        )


class UnsupportedFormat(FragsimError, ValueError):
    """A file that is not a results.h5, or of a format version this reader does not know."""


_BY_STATUS: Dict[int, Type[ApiError]] = {
    400: BadRequest,
    401: Unauthorized,
    403: Forbidden,
    404: NotFound,
    405: MethodNotAllowed,
    408: RequestTimeout,
    409: Conflict,
    411: LengthRequired,
    413: PayloadTooLarge,
    415: UnsupportedMediaType,
    422: Unprocessable,
    431: HeadersTooLarge,
    500: ServerError,
    503: ServiceUnavailable,
    507: StorageFull,
}

_BY_CODE: Dict[str, Type[ApiError]] = {
    "not_ready": NotReady,
    "limit_exceeded": LimitExceeded,
}


def error_class(status: int, code: str) -> Type[ApiError]:
    """The exception class for an error answer of ``status`` with body code ``code``."""
    cls = _BY_CODE.get(code)
    if cls is not None and issubclass(cls, _BY_STATUS.get(status, ApiError)):
        return cls
    if status in _BY_STATUS:
        return _BY_STATUS[status]
    return ServerError if status >= 500 else ApiError


def from_response(
    status: int,
    body: bytes,
    *,
    method: str = "",
    url: str = "",
    retry_after: Optional[float] = None,
) -> ApiError:
    """Builds the exception for an error answer (fragsimd's JSON body, or any other text)."""
    code, message, field = f"http_{status}", "", None
    try:
        doc = json.loads(body.decode("utf-8"))
        if isinstance(doc, dict) and "code" in doc:
            code = str(doc.get("code"))
            message = str(doc.get("message", ""))
            f = doc.get("field")
            field = None if f is None else str(f)
        else:
            message = body.decode("utf-8", "replace")[:500]
    except (ValueError, UnicodeDecodeError):
        message = body.decode("utf-8", "replace")[:500]
    cls = error_class(status, code)
    return cls(
        status, code, message, field, method=method, url=url, retry_after=retry_after, body=body
    )
