"""How the HTTP API answers: refusals (JSON, or plain text for /sparql), SPARQL results, and SPARQL errors
as statuses."""
from __future__ import annotations

from collections.abc import Callable

from flask import Response, jsonify, request
from werkzeug.exceptions import HTTPException

from urdfkb.kb_server.index import QueryOutOfMemory, WorkerCrashed
from urdfkb.kb_server.jobs import QueueFull
from urdfkb.kb_server.results import ResultTooLarge
from urdfkb.kb_server.services import services
from urdfkb.kb_server.sparql import NotAcceptable, QueryError, QueryTimeout, Result
from urdfkb.kb_server.store import ReadOnlyGraph
from urdfkb.pipeline.errors import ShapeError

SPARQL_PATH = "/sparql"  # the protocol's refusals are plain text, as SPARQL clients expect
SPARQL_ERRORS: tuple[tuple[type[Exception], int], ...] = (
    (QueryError, 400), (ShapeError, 400), (ReadOnlyGraph, 403), (NotAcceptable, 406), (ResultTooLarge, 413), (QueryTimeout, 503),
    (QueryOutOfMemory, 503), (WorkerCrashed, 500))


def error(status: int, message: str, plain: bool = False) -> Response:
    """A refusal as JSON, or as text for /sparql; a lone surrogate in `message` is escaped, never a 500."""
    if plain:
        return Response((message + "\n").encode("utf-8", "backslashreplace"), status, mimetype="text/plain")
    return Response(jsonify(error=message).get_data(), status, mimetype="application/json")


def refusal(status: int, message: str) -> Response:
    """A refusal in the form the requested path answers in (see `error`)."""
    return error(status, message, request.path == SPARQL_PATH)


def results(result: Result) -> Response:
    charset = "" if result.media_type.endswith("xml") else "; charset=utf-8"
    return Response(result.body, 200, content_type=result.media_type + charset)


def answer(run: Callable[[], Response]) -> Response:
    """`run()`'s response, or the SPARQL error it raised (SPARQL_ERRORS) as a plain-text status."""
    try:
        return run()
    except tuple(kind for kind, _ in SPARQL_ERRORS) as e:
        return error(next(status for kind, status in SPARQL_ERRORS if isinstance(e, kind)), str(e), True)


def queue_full(e: QueueFull) -> Response:
    """Any route that submits a job: 429 with Retry-After while the queue is full."""
    resp = error(429, str(e))
    resp.headers["Retry-After"] = str(e.retry_after)
    return resp


def http_error(e: HTTPException) -> Response:
    """Flask's own refusals (404, 405, 413...) in the API's form; 413 names the body limit."""
    status = e.code or 500
    messages = {413: f"request body larger than the {services().max_body} byte limit"}
    return refusal(status, messages.get(status, e.description or e.name))


def accepted(job) -> Response:
    """202 for a queued populate job, pointing at its status (a full queue raises QueueFull: 429 in the app)."""
    resp = jsonify(job.to_dict())
    resp.status_code = 202
    resp.headers["Location"] = f"/jobs/{job.id}"
    return resp
