"""What the HTTP routes share: the store, the job manager, the request policy and the server's settings,
kept by the app factory in `app.extensions["urdfkb"]` and read per request through `services()`."""
from __future__ import annotations

import hmac
import threading
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

from flask import current_app, request

from urdfkb.kb_server.jobs import JobManager
from urdfkb.kb_server.security import Policy
from urdfkb.kb_server.store import Store

EXTENSION = "urdfkb"


@dataclass(frozen=True)
class Services:
    """One server's services and settings (see app.create_app for what each setting bounds)."""

    store: Store
    jobs: JobManager
    policy: Policy
    token: str | None
    max_body: int
    query_timeout: float
    max_links: int
    max_waiters: int
    waiters: threading.BoundedSemaphore  # one per client waiting on a job (GET /jobs/<id>?wait=1)
    package_paths: Mapping[str, Path] | None
    trust_xacro: bool
    xacro_timeout: float  # seconds of wall time one xacro expansion may take

    def authorized(self) -> bool:
        """The request carries the server's token (never true when no token is configured)."""
        sent = request.headers.get("Authorization", "")
        return bool(self.token) and hmac.compare_digest(sent.encode(), f"Bearer {self.token}".encode())

    def may_write(self) -> bool:
        """The request may populate or correct: the server has no token, or the request carries it."""
        return not self.token or self.authorized()


def services() -> Services:
    """The services of the app handling this request."""
    return current_app.extensions[EXTENSION]
