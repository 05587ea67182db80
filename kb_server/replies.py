"""How the HTTP API answers: every error in one place (`handle_error`), SPARQL results, and accepted jobs."""
from __future__ import annotations

from flask import Response, jsonify, request
from werkzeug.exceptions import HTTPException

from urdfkb.kb_server import ui
from urdfkb.kb_server.jobs import Job
from urdfkb.kb_server.services import services
from urdfkb.kb_server.sparql import Result
from urdfkb.pipeline.errors import UrdfkbError

SPARQL_PATH = "/sparql"  # the protocol's refusals are plain text, as SPARQL clients expect
SPARQL_REFUSAL_TYPE = "text/plain; charset=utf-8"


def handle_error(e: UrdfkbError | HTTPException) -> Response:
    """The answer to any UrdfkbError a route (or the request checks before it) raised, with the status its
    class carries, and to Flask's own refusals (404, 405, 413...: 413 names the body limit). The message is
    plain text on /sparql, a page for a browser's GET (kb_server.ui), JSON `{"error": message}` otherwise;
    a lone surrogate in it is escaped, never a 500."""
    if isinstance(e, HTTPException):
        status, headers = e.code or 500, {}
        message = f"request body larger than the {services().max_body} byte limit" if status == 413 \
            else e.description or e.name
    else:
        status, headers, message = e.status, e.headers, str(e)
    if request.path == SPARQL_PATH:
        resp = Response(sparql_refusal(message), status, content_type=SPARQL_REFUSAL_TYPE)
    elif request.method == "GET" and ui.wants_html():
        resp = ui.error_page(status, message)
    else:
        resp = Response(jsonify(error=message).get_data(), status, mimetype="application/json")
    resp.headers.update(headers)
    return resp


def sparql_refusal(message: str) -> bytes:
    """The body of a refusal on /sparql (SPARQL_REFUSAL_TYPE): the message on one line; a lone surrogate escaped."""
    return (message + "\n").encode("utf-8", "backslashreplace")


def results_type(media_type: str) -> str:
    """The Content-Type of an answer in `media_type` (UTF-8 said, but for XML, which says it itself)."""
    return media_type + ("" if media_type.endswith("xml") else "; charset=utf-8")


def results(result: Result) -> Response:
    return Response(result.body, 200, content_type=results_type(result.media_type))


def accepted(job: Job) -> Response:
    """202 for a queued populate job, pointing at its status (a full queue raises QueueFull: 429)."""
    resp = jsonify(job.to_dict())
    resp.status_code = 202
    resp.headers["Location"] = f"/jobs/{job.id}"
    return resp
