"""Request bodies over the server's limit answered with the app's 413, which an ordinary client reads.

waitress refuses a body of `max_request_body_size` bytes or more from its Content-Length, answers its own
plain-text 413 and closes the connection while the client is still sending: the kernel then resets
the connection over the unread bytes, and Python's urllib saw "connection reset" (11 MiB) or "broken
pipe" (64 and 200 MiB), never the answer; with `Expect: 100-continue` waitress answered
"100 Continue" first and read the body it was going to refuse. Here:

- the answer is the app's own (kb_server.replies: JSON naming the limit, plain text on /sparql), sent
  at once, before any byte of the body, and the connection is closed after it;
- a client that sent `Expect: 100-continue` gets it instead of "100 Continue", and need send no body;
- otherwise the body that follows (up to its declared length, at most MAX_DISCARD bytes, within the
  body deadline of kb_server.http_deadlines) is read and dropped before the connection is closed, so
  the client finishes sending and then reads the answer waiting for it. Nothing of it is kept.

A chunked body over the limit, or one declaring more than MAX_DISCARD bytes, gets the same answer and
the connection is closed at once, as before. Every answer carries MAX_BODY_HEADER, the limit, so a
client (urdfkb.client) can refuse an oversized body before sending it.
"""
from __future__ import annotations

import functools
import time
from collections.abc import Callable, Iterable
from typing import Any

from flask import Flask
from waitress.adjustments import Adjustments
from waitress.channel import HTTPChannel
from waitress.parser import HTTPRequestParser
from waitress.task import ErrorTask, Task, WSGITask
from waitress.utilities import RequestEntityTooLarge
from werkzeug.exceptions import RequestEntityTooLarge as AppRequestEntityTooLarge

from urdfkb.kb_server.http_deadlines import DeadlineChannel, DeadlineServer
from urdfkb.settings import MAX_DISCARD

MAX_BODY_HEADER = "Urdfkb-Max-Body"  # on every answer: the most bytes a request body may have
DISCARD_READ = 2**20  # bytes read at once while dropping a refused body
REFUSED = "urdfkb.refused_body"  # in the WSGI environ of a request whose body was refused


class BodyTooLarge(RequestEntityTooLarge):
    """waitress's refusal of a body over the limit, answered by the app (RefusedBodyTask)."""


class BodyLimitParser(HTTPRequestParser):
    """waitress's request parser for `channel`, except that a body over the limit is refused as BodyTooLarge,
    `Expect: 100-continue` is then answered with the refusal rather than with "100 Continue", and the bytes
    of the body already received are taken (never parsed as a next request); the channel drops the rest."""

    def __init__(self, adj: Adjustments, channel: BodyLimitChannel):
        super().__init__(adj)
        self.channel = channel

    def received(self, data: bytes) -> int:
        consumed = super().received(data)
        if isinstance(self.error, RequestEntityTooLarge) and not isinstance(self.error, BodyTooLarge):
            declared = 0 if self.chunked or self.expect_continue or self.content_length > MAX_DISCARD \
                else self.content_length
            taken = min(declared, len(data) - consumed)
            self.error, self.expect_continue = BodyTooLarge(self.error.body), False
            self.channel.discard(declared - taken)
            consumed += taken
        return consumed


class RefusedBodyTask(WSGITask):
    """The app's answer to a request whose body was refused: the app sees REFUSED in the environ and an
    empty body; the connection is closed after the answer (and after the rest of the body is dropped)."""

    def get_environment(self) -> dict:
        environ = super().get_environment()
        environ[REFUSED] = True
        return environ

    def execute(self) -> None:
        self.set_close_on_finish()
        super().execute()


def error_task(channel: HTTPChannel, request: HTTPRequestParser) -> Task:
    """The task answering a request waitress refused: the app's 413 for a body over the limit, waitress's
    own plain-text answer for the rest (malformed requests, headers over their limit)."""
    task_class = RefusedBodyTask if isinstance(request.error, BodyTooLarge) else ErrorTask
    return task_class(channel, request)  # type: ignore[arg-type]  # waitress's stubs call a task's request an Error; it is the parser


class BodyLimitChannel(DeadlineChannel):
    """A connection that reads and drops the rest of a refused body (`discarding` bytes more) after the
    refusal, and closes only then (or at the body deadline)."""

    error_task_class = staticmethod(error_task)  # type: ignore[assignment]  # waitress only calls it
    discarding = 0  # bytes of a refused body still to read and drop
    discarding_since = 0.0

    @property
    def parser_class(self) -> Callable[[Adjustments], BodyLimitParser]:  # type: ignore[override]  # waitress calls it with its adjustments only
        return functools.partial(BodyLimitParser, channel=self)

    def discard(self, size: int) -> None:
        """Drop the next `size` bytes received: the rest of a refused body."""
        self.discarding, self.discarding_since = size, time.time()

    def handle_read(self) -> None:
        if not self.discarding:
            return super().handle_read()
        try:  # in large pieces: waitress's 8 KiB reads took 64 MiB in 8,192 turns of the server's loop
            data = self.recv(min(self.discarding, DISCARD_READ))
        except OSError:
            self.handle_close()
            return
        if data:
            self.discarding -= len(data)
            self.last_activity = time.time()
        else:
            self.connected = False

    def readable(self) -> bool:
        return bool(self.discarding and not self.will_close) or super().readable()

    def writable(self) -> bool:
        if self.discarding and not self.total_outbufs_len and not self.will_close:
            return False  # the answer is out: read the rest of the body before closing
        return super().writable()

    def handle_write(self) -> None:
        if not (self.discarding and self.close_when_flushed and not self.will_close):
            return super().handle_write()
        self.close_when_flushed = False  # send the answer, but close only once the body is read
        try:
            super().handle_write()
        finally:
            self.close_when_flushed = True

    def overdue(self, now: float, header_timeout: float, body_timeout: float) -> bool:
        if self.discarding:
            return now - self.discarding_since > body_timeout
        return super().overdue(now, header_timeout, body_timeout)


class BodyLimitServer(DeadlineServer):
    """DeadlineServer with BodyLimitChannel's refusals of oversized bodies, serving the Flask `app` (wrapped by
    answering_refused_bodies); `max_body` is the most bytes a request body may have."""

    channel_class = BodyLimitChannel

    def __init__(self, app: Flask, max_body: int, header_timeout: float, body_timeout: float, **adjustments: Any):
        super().__init__(answering_refused_bodies(app, max_body), header_timeout, body_timeout,
                         max_request_body_size=max_body + 1, **adjustments)


def answering_refused_bodies(app: Flask, max_body: int) -> Callable:
    """`app` as a WSGI application that answers a request marked REFUSED with the app's own 413 (its error
    handler and its after-request hooks, no route), and adds MAX_BODY_HEADER to every answer."""
    limit = (MAX_BODY_HEADER, str(max_body))

    def wsgi(environ: dict, start_response: Callable) -> Iterable[bytes]:
        def respond(status: str, headers: list, exc_info=None):
            return start_response(status, [*headers, limit], exc_info)

        if environ.get(REFUSED):
            with app.request_context(environ):
                response = app.finalize_request(app.handle_user_exception(AppRequestEntityTooLarge()))
            return response(environ, respond)
        return app(environ, respond)
    return wsgi
