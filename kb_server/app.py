"""The HTTP API's app factory: one Flask app over a store and a job manager.

The routes are blueprints by resource in kb_server/routes/: `sparql` (the SPARQL 1.1 Protocol at
/sparql), `jobs` (POST /populate, POST /robots/<name>/populate, GET /jobs/<id>), `robots`,
`corrections`, `queries` and `pages` (the index page); kb_server/ui.py renders the pages. The store,
the jobs and the settings are kept in `app.extensions` (kb_server/services.py), where every blueprint
reads them per request. Routes refuse by raising a UrdfkbError, whose class carries its status;
kb_server/replies.py answers them all in one place (`handle_error`), and builds the SPARQL answers.

Writes (SPARQL updates, DELETE /robots/<name>, and, when a token is configured, populating and
corrections) need `Authorization: Bearer <token>`; with no token configured, updates and deletes are
refused. Every request first passes the checks of kb_server.security (Host, cross-site writes).
"""
from __future__ import annotations

import threading
from collections.abc import Mapping
from pathlib import Path

from flask import Flask
from werkzeug.exceptions import HTTPException

from urdfkb.kb_server.jobs import JobManager
from urdfkb.kb_server.replies import handle_error
from urdfkb.kb_server.ask import Asker
from urdfkb.kb_server.routes import BLUEPRINTS, ask
from urdfkb.kb_server.security import Policy
from urdfkb.kb_server.services import EXTENSION, Services
from urdfkb.kb_server.store import Store
from urdfkb.pipeline.errors import UrdfkbError
from urdfkb.settings import MAX_BYTES, MAX_LINKS, QUERY_TIMEOUT, THREADS, XACRO_TIMEOUT, job_waiters


def create_app(store: Store, jobs: JobManager, token: str | None = None, max_body: int = MAX_BYTES,
               query_timeout: float = QUERY_TIMEOUT, policy: Policy | None = None, max_links: int = MAX_LINKS,
               max_waiters: int = job_waiters(THREADS), package_paths: Mapping[str, Path] | None = None,
               trust_xacro: bool = False, xacro_timeout: float = XACRO_TIMEOUT, asker: Asker | None = None) -> Flask:
    """The Flask app over `store`; populate jobs go to `jobs`; bodies over `max_body` bytes get 413.

    `policy` (default: a loopback server with nothing opened) checks every request; at most
    `max_waiters` clients wait on a job at once (GET /jobs/<id>?wait=1), so waits never hold
    every server thread. Uploaded xacro files may include only from `package_paths` (none: they
    read no server file), inside the sandbox of pipeline.reading.sandbox unless `trust_xacro`; expansion
    is the job's first step, never the request's, and fails past `xacro_timeout` seconds. Questions in words
    (GET /ask) go to `asker`, by default one on the jobs' model thread."""
    app = Flask(__name__)
    app.config["MAX_CONTENT_LENGTH"] = max_body
    kb = Services(store, jobs, policy or Policy(), token, max_body, query_timeout, max_links, max_waiters,
                  threading.BoundedSemaphore(max_waiters), package_paths, trust_xacro, xacro_timeout)
    app.extensions[EXTENSION] = kb
    app.extensions[ask.EXTENSION] = asker
    kb.policy.install(app)
    app.register_error_handler(UrdfkbError, handle_error)
    app.register_error_handler(HTTPException, handle_error)
    for blueprint in BLUEPRINTS:
        app.register_blueprint(blueprint)
    return app
