"""`urdfkb serve`: the app under waitress over a persistent store (on loopback, settings.HOST, unless told otherwise)."""
from __future__ import annotations

import logging
import resource
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from urdfkb.kb_server.app import create_app
from urdfkb.kb_server.jobs import JobManager, Runner, pipeline_runner
from urdfkb.kb_server.remote import RemoteStore
from urdfkb.kb_server.results import ResultLimits
from urdfkb.kb_server.security import Policy, check_bind
from urdfkb.kb_server.services import EXTENSION
from urdfkb.kb_server.sparql_front import SparqlServer
from urdfkb.kb_server.startup import check_port, check_store, listen_error
from urdfkb.kb_server.store import Store, check_robot_name
from urdfkb.pipeline.reading import sandbox
from urdfkb.pipeline.errors import UrdfkbError
from urdfkb.pipeline.runner import Settings
from urdfkb.pipeline.reading.xacro_input import load_description, parse_package_paths
from urdfkb.settings import (BODY_TIMEOUT, CHANNEL_TIMEOUT, HEADER_TIMEOUT, HOST, MAX_BYTES, MAX_CONNECTIONS, MAX_HEADER,
                             MAX_LINKS, MAX_RESULT_BYTES, MAX_RESULT_ROWS, PORT, QUERY_MEMORY, QUERY_TIMEOUT, RESULT_CACHE,
                             THREADS, XACRO_TIMEOUT, job_waiters)

log = logging.getLogger(__name__)
FD_RESERVE = 256  # descriptors besides the connections': store files, worker pipes, the listening socket


def make_server(store_path: str | Path | None = None, host: str = HOST, port: int = PORT,
                token: str | None = None, remote_store: str | None = None, query_timeout: float = QUERY_TIMEOUT,
                max_body: int = MAX_BYTES, threads: int = THREADS, runner: Runner = pipeline_runner,
                allowed_hosts: Sequence[str] = (), model_dir: str | Path | None = None,
                llm_urls: Sequence[str] = (), insecure_no_token: bool = False,
                max_links: int = MAX_LINKS, max_header: int = MAX_HEADER,
                package_paths: dict[str, Path] | None = None, trust_xacro: bool = False,
                xacro_timeout: float = XACRO_TIMEOUT,
                max_result_rows: int = MAX_RESULT_ROWS, max_result_bytes: int = MAX_RESULT_BYTES,
                max_connections: int = MAX_CONNECTIONS, channel_timeout: int = CHANNEL_TIMEOUT,
                header_timeout: float = HEADER_TIMEOUT, body_timeout: float = BODY_TIMEOUT,
                query_memory: int = QUERY_MEMORY, result_cache: int = RESULT_CACHE) -> tuple[SparqlServer, Store, JobManager]:
    """Open the store and bind the server (port 0 picks a free port: see server.effective_port).

    A non-loopback `host` needs a token unless `insecure_no_token`; `allowed_hosts`,
    `model_dir` and `llm_urls` open what kb_server.security refuses by default. Request
    headers over `max_header` bytes are refused (431), query answers past `max_result_rows` or
    `max_result_bytes` (413); a query worker needing more than `query_memory` bytes is
    stopped (503). Up to `result_cache` bytes of answers are kept until the next write (0: none). At most `max_connections` clients are connected at once (slow ones
    hold no thread: waitress hands a request over once it has all of it); at the limit a new one
    closes the connection waiting longest for a complete request (kb_server.http_deadlines). A
    connection is closed when idle for `channel_timeout` seconds, or when a request's headers take
    longer than `header_timeout` seconds from its first byte, or its body `body_timeout` seconds
    more. With a remote store, every robot already stored is
    mirrored to it in the background. Uploaded xacro files are expanded inside pipeline.reading.sandbox, or
    refused where it is unavailable, unless `trust_xacro`; an expansion fails past `xacro_timeout` s."""
    check_bind(host, token, insecure_no_token)
    check_port(port)
    if min(max_connections, channel_timeout, header_timeout, body_timeout) < 1:
        raise UrdfkbError("--max-connections, --channel-timeout, --header-timeout and --body-timeout must be at least 1")
    if not xacro_timeout > 0:
        raise UrdfkbError("--xacro-timeout must be more than 0 seconds")
    if result_cache < 0:
        raise UrdfkbError("--result-cache must be 0 (no cache) or more MiB")
    policy = Policy(host, port, allowed_hosts, model_dir, llm_urls)
    connections = open_files_for(max_connections)
    store = Store(check_store(store_path), limits=ResultLimits(max_result_rows, max_result_bytes, query_memory),
                  result_cache=result_cache)
    jobs = JobManager(store, runner, RemoteStore(remote_store) if remote_store else None)
    app = create_app(store, jobs, token=token, max_body=max_body, query_timeout=query_timeout, policy=policy,
                     max_links=max_links, max_waiters=job_waiters(threads), package_paths=package_paths,
                     trust_xacro=trust_xacro, xacro_timeout=xacro_timeout)
    # waitress buffers a whole request before the app sees it, so bodies over max_body are refused (with the
    # app's 413: kb_server.http_bodies) before they fill memory or a temporary file; poll(), unlike
    # select(), takes descriptors past 1023. With a request lookahead of 1 the I/O thread keeps polling a connection
    # while its request is answered, so an answer of kb_server.sparql_front needs no wake-up of that thread.
    try:
        server = SparqlServer(app, app.extensions[EXTENSION], max_body, header_timeout, body_timeout, host=host,
                              port=port, threads=threads,
                              max_request_header_size=max_header, connection_limit=connections,
                              channel_timeout=channel_timeout, cleanup_interval=1, asyncore_use_poll=True,
                              channel_request_lookahead=1)
    except OSError as e:
        jobs.shutdown()
        store.close()
        raise listen_error(host, port, e) from None
    jobs.mirror_all()
    policy.port = int(server.effective_port)
    return server, store, jobs


def open_files_for(connections: int) -> int:
    """Raise this process's soft limit on open files (within the hard limit) so that `connections` fit,
    two descriptors each (the socket, and a request body spooled to a file) plus FD_RESERVE; returns
    how many connections do fit, fewer than asked (with a warning) only under a lower hard limit."""
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    need = 2 * connections + FD_RESERVE
    if soft != resource.RLIM_INFINITY and soft < need:
        soft = need if hard == resource.RLIM_INFINITY else min(need, hard)
        resource.setrlimit(resource.RLIMIT_NOFILE, (soft, hard))
    if soft == resource.RLIM_INFINITY or soft >= need:
        return connections
    fit = max(1, (soft - FD_RESERVE) // 2)
    log.warning("the open-files limit (%d, hard) leaves room for %d connections, not %d", soft, fit, connections)
    return fit


def serve(store_path: str | Path | None = None, host: str = HOST, port: int = PORT,
          token: str | None = None, remote_store: str | None = None, populate: Sequence[str] = (),
          query_timeout: float = QUERY_TIMEOUT, max_body: int = MAX_BYTES, threads: int = THREADS,
          package_paths: Sequence[str] = (), **options: Any) -> None:
    """Serve until interrupted; the store path defaults to user_data_dir("urdfkb")/kb.sqlite3.

    Each URDF or xacro in `populate` is ingested first (a bad one raises URDFError before anything
    is served) and populated with default settings as a background job, logged when it finishes.
    `package_paths` (NAME=DIR) are the only folders uploaded xacro files may include from;
    `options` are make_server's security and limit options.
    """
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(name)s: %(message)s")
    packages = parse_package_paths(package_paths)
    trees = [load_description(path, packages=packages, max_bytes=max_body, max_links=options.get("max_links", MAX_LINKS),
                              timeout=options.get("xacro_timeout", XACRO_TIMEOUT)) for path in populate]
    for tree in trees:
        check_robot_name(tree.robot_name)
    server, store, jobs = make_server(store_path, host, port, token, remote_store, query_timeout, max_body, threads,
                                      package_paths=packages, **options)
    for tree in trees:
        jobs.submit(tree, tree.robot_name, Settings())
    if options.get("trust_xacro"):
        log.warning("--trust-xacro: uploaded xacro files run unconfined, as this server's user")
    elif reason := sandbox.unavailable():
        log.warning("xacro uploads need the sandbox, and are refused (403) until it can run: %s; plain URDF uploads "
                    "work (see docs/xacro.md)", reason)
    port = server.effective_port
    log.info("serving %s at http://%s:%s/ (SPARQL at /sparql)", store.path, host, port)
    try:
        server.run()
    except KeyboardInterrupt:
        pass
    finally:
        server.close()
        jobs.shutdown()
        store.close()
