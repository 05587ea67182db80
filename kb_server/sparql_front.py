"""SPARQL queries answered where waitress finishes reading them, without a task thread and without Flask.

waitress reads and parses requests in its I/O thread and hands each to one of its task threads, which runs
the app and wakes the I/O thread again to send what is left. For a cheap query that was most of the time:
with 100 PR2 copies, `sensors` took 2.2 ms end to end of which the engine 0.27 ms and its JSON writer 0.09;
Flask's request handling took 0.32 ms and waitress's dispatch, the thread hand-offs and the sockets
about 1.3 ms (benchmarks/sparql_breakdown.py, before this module). A trivial WSGI app under waitress
answered 694 requests/s to one client where a trivial asyncio server answered 2,135, and Oxigraph's
own server answers `sensors` at 973/s. So waitress stays the HTTP server (its parser, body and header
limits, deadlines and connection limit: kb_server.http_bodies, kb_server.http_deadlines), but its task
queue and Flask are set aside for the one request the endpoint answers most:

`SparqlServer.add_task`, called where a request has been read whole, gives the request to `SparqlFront`.
A SPARQL query (GET with `query`, a form POST with `query`, or an application/sparql-query POST, to
/sparql) that passes the request checks of kb_server.security (Host; Origin and Sec-Fetch-Site of a POST)
is answered at once from the result cache (kb_server/result_cache.py) if it holds the answer, in the thread that
read it; else it is handed to a free query worker (Index.submit_query), and the I/O thread goes on serving. The
index's answering thread writes the answer, or the query's refusal, to the connection when it comes. Everything
else -- updates, the service description and the query page, every refusal of the request itself (a bad
Host, a cross-site POST, both query and update, a malformed form), multipart forms -- goes to the Flask
app as before; the app's /sparql route answers the same queries the same way under any other WSGI server.
"""
from __future__ import annotations

import functools
import time
from functools import lru_cache
from typing import Any
from urllib.parse import parse_qsl

import werkzeug.urls  # noqa: F401  # registers the "werkzeug.url_quote" codec error handler, as the app's parser uses
from flask import Flask
from waitress.channel import ClientDisconnected, HTTPChannel
from waitress.parser import HTTPRequestParser
from waitress.utilities import build_http_date
from werkzeug.http import HTTP_STATUS_CODES

from urdfkb.kb_server.http_bodies import MAX_BODY_HEADER, BodyLimitServer
from urdfkb.kb_server.index import IndexClosed
from urdfkb.kb_server.replies import SPARQL_PATH, SPARQL_REFUSAL_TYPE, results_type, sparql_refusal
from urdfkb.kb_server.result_cache import no_cache
from urdfkb.kb_server.services import Services
from urdfkb.kb_server.sparql import SCAN_CACHE, SCAN_CACHE_TEXT, Result, protocol_dataset
from urdfkb.pipeline.errors import UrdfkbError

FORM = "application/x-www-form-urlencoded"
QUERY_BODY = "application/sparql-query"
# text, Accept, default and named graphs, and whether the answer must be evaluated afresh (Cache-Control: no-cache)
Query = tuple[str, str | None, list[str] | None, list[str] | None, bool]


@lru_cache(maxsize=SCAN_CACHE)
def _decoded(text: bytes) -> tuple[tuple[str, str], ...]:
    return tuple(parse_qsl(text.decode(), keep_blank_values=True, errors="werkzeug.url_quote"))


def _fields(text: bytes) -> tuple[tuple[str, str], ...]:
    """Fields of a query string or form body, decoded as the app's request parser decodes them (werkzeug). What a
    text up to SCAN_CACHE_TEXT bytes gives is kept, as its query's checks are (kb_server.sparql.scan): clients send
    the same queries again and again, and decoding a 3 KB form took 0.1-0.3 ms."""
    return _decoded(text) if len(text) <= SCAN_CACHE_TEXT else _decoded.__wrapped__(text)


def _first(fields: tuple[tuple[str, str], ...], name: str) -> str | None:
    return next((v for k, v in fields if k == name), None)


class SparqlFront:
    """Answers SPARQL queries on waitress's connections for the app's services `kb`; every answer carries
    MAX_BODY_HEADER (`max_body`) and the `ident` waitress sends, as the app's answers do."""

    def __init__(self, kb: Services, max_body: int, ident: str):
        self.kb = kb
        self.host_allowed = lru_cache(maxsize=64)(kb.policy.host_allowed)  # the Host values seen; each checked once
        self.fixed = [(MAX_BODY_HEADER, str(max_body)), *([("Server", ident)] if ident else [])]

    def query(self, request: HTTPRequestParser) -> Query | None:
        """The query a request parsed by waitress asks, if it is one this front answers; None for the app."""
        if request.error or request.path != SPARQL_PATH or request.command not in ("GET", "POST"):  # type: ignore[attr-defined]
            return None
        headers = request.headers
        host = headers.get("HOST", "")
        if not self.host_allowed(host):
            return None
        try:
            fields = _fields(request.query.encode("latin-1"))  # type: ignore[attr-defined]
            if request.command == "GET":
                query, update = _first(fields, "query"), _first(fields, "update")
            else:
                if self.kb.policy.cross_site("POST", headers.get("ORIGIN"), headers.get("SEC_FETCH_SITE"), host):
                    return None
                mimetype = headers.get("CONTENT_TYPE", "").partition(";")[0].strip().lower()
                if mimetype not in (FORM, QUERY_BODY):
                    return None
                stream = request.get_body_stream()
                start = stream.tell()
                body = stream.read()
                stream.seek(start)  # as it was, should the app read it
                if mimetype == QUERY_BODY:
                    query, update = body.decode(errors="replace"), None
                else:
                    form = _fields(body)
                    query, update = _first(form, "query"), _first(form, "update")
                    fields = fields + form
        except UnicodeError:  # the app refuses it
            return None
        if query is None or update is not None:
            return None
        default, named = protocol_dataset([v for k, v in fields if k == "default-graph-uri"],
                                          [v for k, v in fields if k == "named-graph-uri"])
        return query, headers.get("ACCEPT"), default, named, no_cache(headers.get("CACHE_CONTROL"))

    def take(self, server: SparqlServer, channel: HTTPChannel) -> bool:
        """Answer the channel's first request here if it is a query (see `query`); False: it is the app's.

        Called where waitress adds a task, with the channel's requests lock held. A query whose answer the result
        cache holds is answered at once, in this thread, and so is each cached one pipelined after it; the first
        that is not goes to a worker, or to the app."""
        index = self.kb.store.index
        while channel.requests:
            if channel.close_when_flushed:  # read behind an answer that closes the connection: never answered
                for waiting in channel.requests:
                    waiting.close()
                channel.requests = []
                return True
            request = channel.requests[0]
            query = self.query(request) if index.workers else None  # no workers: the app evaluates in-process
            if query is None:
                return False
            text, accept, default, named, fresh = query
            kept = None if fresh or channel.total_outbufs_len else index.cached(text, accept, default, named)
            if kept is None:  # (with output waiting, writing here could wait for this very thread to send it)
                try:
                    index.submit_query(text, accept, self.kb.query_timeout, default, named,
                                       functools.partial(self._answer, server, channel, request))
                except IndexClosed:  # stopping: the app answers 503
                    return False
                return True
            close = self._write(channel, request, kept, None)
            self._next(server, channel, request, close, follow=False)
        return True

    def _answer(self, server: SparqlServer, channel: HTTPChannel, request: HTTPRequestParser,
                result: Result | None, error: UrdfkbError | None) -> None:
        """(In the index's answering thread) write the answer, then serve the channel's next request, as
        waitress's HTTPChannel.service does after a task."""
        close = self._write(channel, request, result, error)
        with channel.requests_lock:  # type: ignore[attr-defined]  # waitress's, not in its stubs
            self._next(server, channel, request, close, follow=True)

    def _write(self, channel: HTTPChannel, request: HTTPRequestParser, result: Result | None,
               error: UrdfkbError | None) -> bool:
        """Send the answer (or the refusal) to `request`; True if the connection is to close after it."""
        if error is None:
            assert result is not None
            status, headers, body = 200, [("Content-Type", results_type(result.media_type))], result.body
        else:
            status, headers = error.status, [("Content-Type", SPARQL_REFUSAL_TYPE), *error.headers.items()]
            body = sparql_refusal(str(error))
        connection = request.headers.get("CONNECTION", "").lower()
        close = connection == "close" if request.version == "1.1" else connection != "keep-alive"
        if close or request.version != "1.1":
            headers.append(("Connection", "close" if close else "Keep-Alive"))
        headers += [("Content-Length", str(len(body))), ("Date", build_http_date(int(time.time()))), *self.fixed]
        head = "".join(f"{name}: {value}\r\n" for name, value in sorted(headers, key=lambda h: h[0]))
        data = f"HTTP/{request.version} {status} {HTTP_STATUS_CODES[status].upper()}\r\n{head}\r\n".encode("latin-1") + body
        with channel.outbuf_lock:  # type: ignore[attr-defined]  # waitress's, not in its stubs
            # Straight to the socket when nothing waits before it: through the out-buffers, the I/O thread could find
            # them full for an instant and leave the connection out of its poll for a whole loop timeout (1 s; seen).
            sent = channel.send(data, do_close=False) if channel.connected and not channel.total_outbufs_len else 0
        try:
            if sent < len(data):  # the rest, sent by the I/O thread (woken in _next)
                channel.write_soon(data[sent:])
        except ClientDisconnected:
            close = True
        return close

    def _next(self, server: SparqlServer, channel: HTTPChannel, request: HTTPRequestParser, close: bool,
              follow: bool) -> None:
        """(With the channel's requests lock held) done with `request`: close the connection, or drop the request and,
        if `follow`, hand the next one on (else the caller takes it); then have the I/O thread send what waits."""
        request.close()
        pipelined = len(channel.requests) > 1  # the I/O thread may have stopped reading the connection
        if close:
            channel.close_when_flushed = True
            for waiting in channel.requests[1:]:
                waiting.close()
            channel.requests = []
        else:
            channel.requests.pop(0)  # type: ignore[attr-defined]  # a list; the stubs say Sequence
            if channel.connected and channel.requests:
                if follow:
                    server.add_task(channel)
            elif channel.connected and (reading := channel.request) is not None and reading.expect_continue \
                    and reading.headers_finished and not channel.sent_continue:
                channel.send_continue()
        channel.last_activity = time.time()
        if close or pipelined or channel.total_outbufs_len or not server.adj.channel_request_lookahead:
            server.pull_trigger()  # else the I/O thread polls the connection already (a request lookahead of 1)


class SparqlServer(BodyLimitServer):
    """BodyLimitServer whose SPARQL queries are answered by a SparqlFront over the app's services `kb`, the rest
    by the app."""

    def __init__(self, app: Flask, kb: Services, max_body: int, header_timeout: float, body_timeout: float,
                 **adjustments: Any):
        super().__init__(app, max_body, header_timeout, body_timeout, **adjustments)
        self.front = SparqlFront(kb, max_body, self.adj.ident)

    def add_task(self, task: HTTPChannel) -> None:  # type: ignore[override]  # waitress passes the channel
        if not self.front.take(self, task):
            super().add_task(task)  # type: ignore[arg-type]
