"""The MCP tools over streamable HTTP: POST /mcp (kb_server.mcp_tools's server through kb_server.mcp_http's bridge).

Only POST is served (stateless JSON answers: no stream to open with GET, no session to end with DELETE;
both get 405, which the transport's specification allows). The request has passed the app's Host and
Origin checks and its body the size limit; where the server has a token, the request must carry it.
"""
from __future__ import annotations

import threading

from flask import Blueprint, Response, current_app, request

from urdfkb.kb_server.errors import Forbidden
from urdfkb.kb_server.mcp_http import HttpBridge
from urdfkb.kb_server.mcp_tools import mcp_server
from urdfkb.kb_server.services import services
from urdfkb.kb_server.sparql import QueryTimeout

bp = Blueprint("mcp", __name__)
EXTENSION = "urdfkb.mcp"
MARGIN = 5.0  # seconds the bridge waits beyond the query timeout (a tool call runs one query)
_making = threading.Lock()
# Hop-by-hop and framing headers are the WSGI server's to write.
_DROPPED = ("content-length", "transfer-encoding", "connection")


def bridge() -> HttpBridge:
    """The app's bridge, made at its first MCP request."""
    with _making:
        if EXTENSION not in current_app.extensions:
            kb = services()
            current_app.extensions[EXTENSION] = HttpBridge(mcp_server(kb.store, kb.query_timeout), kb.max_body)
        return current_app.extensions[EXTENSION]


@bp.post("/mcp")
def mcp() -> Response:
    kb = services()
    if not kb.may_write():
        raise Forbidden("the MCP tools need the server's token (Authorization: Bearer ...)")
    port = request.environ.get("SERVER_PORT", "80")
    try:
        answer = bridge().handle("POST", request.path, request.query_string, dict(request.headers), request.get_data(),
                                 (request.environ.get("SERVER_NAME", ""), int(port)), kb.query_timeout + MARGIN)
    except TimeoutError:
        raise QueryTimeout(f"the MCP request took longer than {kb.query_timeout + MARGIN:g} s") from None
    resp = Response(answer.body, answer.status)
    for name, value in answer.headers:
        if name.lower() not in _DROPPED:
            resp.headers[name] = value
    return resp
