"""Deadlines for receiving a request, on top of waitress's idle timeout (as nginx's client_header_timeout
and client_body_timeout).

waitress closes a connection only after `channel_timeout` seconds with nothing received or sent, so a
client sending a byte every few seconds kept its connection for good, and 1,010 of them filled the
connection limit: every other client waited in the listen backlog. Here each connection notes when the
request it is receiving began and when its headers were complete; every `cleanup_interval` the server
closes those whose headers took longer than `header_timeout`, or body longer than `body_timeout`. And at
the connection limit the server still accepts, closing the connection that has waited longest without a
complete request (a slow request's first byte, an idle one's last activity), so that a new client is
never stuck behind slow ones. Connections whose request is being served, or whose answer is being
sent, are never closed early.
"""
from __future__ import annotations

import time
from typing import TYPE_CHECKING, Any

from waitress.adjustments import Adjustments
from waitress.channel import HTTPChannel
from waitress.server import TcpWSGIServer

if TYPE_CHECKING:
    from _typeshed.wsgi import WSGIApplication


class DeadlineChannel(HTTPChannel):
    """An HTTP connection that knows since when it has been receiving its current request."""

    started: float | None = None  # the request being received: when its first byte came
    headers_done: float | None = None  # ...and when its headers were complete
    _receiving = None  # that request's parser

    def received(self, data: bytes) -> bool:
        done = super().received(data)
        self._clock(time.time())
        return done

    def _clock(self, now: float) -> None:
        request = self.request
        if request is not self._receiving:
            self.started, self.headers_done, self._receiving = (None if request is None else now), None, request
        if request is not None and request.headers_finished and self.headers_done is None:
            self.headers_done = now

    def overdue(self, now: float, header_timeout: float, body_timeout: float) -> bool:
        """Whether the request being received is past its deadline: headers `header_timeout` seconds after
        its first byte, body `body_timeout` seconds after its headers."""
        if self.started is None or self.requests:
            return False
        if self.headers_done is None:
            return now - self.started > header_timeout
        return now - self.headers_done > body_timeout

    def waiting_since(self) -> float | None:
        """Since when this connection has waited for a complete request; None while one is served or
        answered, or once it is closing."""
        if self.requests or self.total_outbufs_len or self.will_close or self.close_when_flushed:
            return None
        return self.started or self.last_activity


class DeadlineServer(TcpWSGIServer):
    """waitress's TCP server with DeadlineChannel's deadlines, which keeps accepting at the connection limit
    (see the module docstring); `adjustments` are waitress's (one listen address)."""

    channel_class = DeadlineChannel
    effective_host: str  # where waitress bound the socket, set as it binds (its stubs leave them out)
    effective_port: int

    def __init__(self, application: WSGIApplication, header_timeout: float, body_timeout: float, **adjustments: Any):
        self.header_timeout, self.body_timeout = header_timeout, body_timeout
        super().__init__(application, adj=Adjustments(**adjustments))

    def readable(self) -> bool:
        now = time.time()
        if now >= self.next_channel_cleanup:
            self.next_channel_cleanup = now + self.adj.cleanup_interval  # type: ignore[assignment]  # stubs: int
            self.maintenance(now)
        connections = len(self._map)  # type: ignore[attr-defined]  # asyncore's socket map, not in the stubs
        return self.accepting and (connections < self.adj.connection_limit or self._longest_waiting() is not None)

    def maintenance(self, now: float) -> None:
        super().maintenance(now)  # type: ignore[arg-type]  # waitress's idle timeout; it passes time.time() too
        for channel in self.active_channels.values():  # type: ignore[attr-defined]  # a dict; stubs say a channel
            if channel.overdue(now, self.header_timeout, self.body_timeout):
                channel.will_close = True

    def handle_accept(self) -> None:
        if len(self._map) >= self.adj.connection_limit and (  # type: ignore[attr-defined]  # asyncore's map
                oldest := self._longest_waiting()) is not None:
            oldest.will_close = True  # closed by the loop's next pass, after the new socket has its descriptor
        super().handle_accept()

    def _longest_waiting(self) -> DeadlineChannel | None:
        waiting = [(since, channel) for channel in self.active_channels.values()  # type: ignore[attr-defined]
                   if (since := channel.waiting_since()) is not None]
        return min(waiting, key=lambda pair: pair[0])[1] if waiting else None
