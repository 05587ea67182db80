"""The MCP server's streamable HTTP transport inside the WSGI app: one request handed to the SDK's ASGI handler.

The SDK serves streamable HTTP as ASGI (Starlette), and `urdfkb serve` is WSGI (Flask under waitress,
whose request checks, size limits and error answers every route shares). Rather than a second server
on a second port, or an ASGI-to-WSGI adapter between the whole app and the SDK, one event loop runs in
a daemon thread, holding the SDK's session manager open (its lifespan); the /mcp route hands it each
request, whole (waitress has buffered the body), and waits for the whole answer. The manager runs
stateless with JSON answers: every POST carries a complete exchange and gets one JSON body back, so
no stream outlives its request, nothing stays in memory between requests, and a waitress thread
waits at most the query timeout. The SDK's own Host and Origin checks are off: the app's Policy
(kb_server.security) has made them, for /mcp as for every route, before the request gets here.
"""
from __future__ import annotations

import asyncio
import threading
from collections.abc import Mapping, MutableMapping
from dataclasses import dataclass
from typing import Any

from mcp.server import Server
from mcp.server.streamable_http_manager import StreamableHTTPSessionManager


@dataclass(frozen=True)
class Answer:
    status: int
    headers: list[tuple[str, str]]
    body: bytes


class HttpBridge:
    """`server`'s streamable HTTP transport on its own event-loop thread, started at the first request."""

    def __init__(self, server: Server, max_body: int):
        self.manager = StreamableHTTPSessionManager(app=server, json_response=True, stateless=True,
                                                    max_request_body_size=max_body)
        self._loop: asyncio.AbstractEventLoop | None = None
        self._start = threading.Lock()

    def _running_loop(self) -> asyncio.AbstractEventLoop:
        with self._start:
            if self._loop is None:
                ready = threading.Event()
                loop = asyncio.new_event_loop()

                async def hold_open() -> None:
                    async with self.manager.run():
                        ready.set()
                        await asyncio.Event().wait()  # until the process ends (a daemon thread)

                threading.Thread(target=loop.run_until_complete, args=(hold_open(),), name="urdfkb-mcp",
                                 daemon=True).start()
                ready.wait()
                self._loop = loop
            return self._loop

    def handle(self, method: str, path: str, query: bytes, headers: Mapping[str, str], body: bytes,
               server: tuple[str, int], timeout: float) -> Answer:
        """The SDK's answer to one HTTP request; TimeoutError past `timeout` seconds."""
        future = asyncio.run_coroutine_threadsafe(self._request(method, path, query, headers, body, server),
                                                  self._running_loop())
        return future.result(timeout)

    async def _request(self, method: str, path: str, query: bytes, headers: Mapping[str, str], body: bytes,
                       server: tuple[str, int]) -> Answer:
        scope = {"type": "http", "asgi": {"version": "3.0"}, "http_version": "1.1", "method": method,
                 "scheme": "http", "path": path, "raw_path": path.encode(), "query_string": query, "root_path": "",
                 "headers": [(k.lower().encode("latin-1"), v.encode("latin-1")) for k, v in headers.items()],
                 "server": server, "client": None}
        sent = asyncio.Event()
        delivered = False
        start: dict = {}
        chunks: list[bytes] = []

        async def receive() -> dict:
            nonlocal delivered
            if not delivered:
                delivered = True
                return {"type": "http.request", "body": body, "more_body": False}
            await sent.wait()  # the client stays connected until the whole answer is sent
            return {"type": "http.disconnect"}

        async def send(message: MutableMapping[str, Any]) -> None:
            if message["type"] == "http.response.start":
                start.update(message)
            elif message["type"] == "http.response.body":
                chunks.append(message.get("body", b""))
                if not message.get("more_body", False):
                    sent.set()

        await self.manager.handle_request(scope, receive, send)
        return Answer(start.get("status", 500),
                      [(k.decode("latin-1"), v.decode("latin-1")) for k, v in start.get("headers", [])], b"".join(chunks))
