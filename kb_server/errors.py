"""The server's refusals of a request that belong to no one module: a missing token, a missing or malformed
parameter, an unknown job. Routes raise them as every other module raises its own UrdfkbError subclasses;
kb_server.replies.handle_error answers them all."""
from __future__ import annotations

from urdfkb.pipeline.errors import UrdfkbError


class BadRequest(UrdfkbError):
    """A request missing something it needs, or holding something malformed; the message says what."""

    status = 400


class Forbidden(UrdfkbError):
    """A request this server does not allow: without its token, from another site, or asking what the
    operator has not opened."""

    status = 403


class NotFound(UrdfkbError):
    """Nothing at this path (a job forgotten, an export format that does not exist...)."""

    status = 404


class UnsupportedMediaType(UrdfkbError):
    """A body of a media type the route does not read."""

    status = 415


class TooManyRequests(UrdfkbError):
    """The server is busy with requests of this kind; retry after `retry_after` seconds."""

    status = 429

    def __init__(self, message: str, retry_after: int):
        super().__init__(message)
        self.retry_after = retry_after

    @property
    def headers(self) -> dict[str, str]:
        return {"Retry-After": str(self.retry_after)}


class ServiceUnavailable(UrdfkbError):
    """Something this request needs that the server does not run (the embedded model, for a question in words)."""

    status = 503


class StorageFault(UrdfkbError):
    """The store's disk refused a write (a read-only file or disk, an I/O error), so nothing was written; the
    message names the disk (the store file's directory). An operational fault for whoever runs the server, not
    a bug: logged without a traceback."""

    status = 503


class DiskFull(StorageFault):
    """The disk holding the store is full, so nothing was written."""

    status = 507
