"""The SPARQL index: every graph of the quadstore in Oxigraph, queried in worker processes.

The owlready2 quadstore stays the store of record; this index is derived from it (rebuilt at
start) and kept in step by the store's writes. A master pyoxigraph Store lives in this process;
each of `workers` worker processes holds a replica and answers one operation at a time.

Each worker is confined before it reads anything: a seccomp filter refuses it every socket (pyoxigraph
has an HTTP client that SERVICE and LOAD would use: the lexical checks of kb_server/sparql.py refuse
those, and this makes any gap in them harmless), and an address-space limit (ResultLimits.memory) makes
a query that needs more memory end its worker at once (QueryOutOfMemory, 503) instead of taking the
machine's memory from other clients.

Why processes: pyoxigraph 0.5 cannot cancel a running query (Oxigraph's Rust API can, its Python
binding does not expose it) and evaluates outside the GIL with no hook, so a query past its
deadline would keep a core busy for as long as it likes (measured: a 100k-item IN filter over 3,000
triples runs 54 s in one call). A worker past the deadline is killed and replaced from the master,
so a deadline is a deadline; a crash in Oxigraph costs one worker, not the server. Readers on
different workers never wait for each other, nor for a populate or a write: a write is queued
behind whatever its worker is answering, and each operation carries the sequence number of the
last write it must see, so a query sent after a write returned sees it. An update is evaluated on
one replica and undone there: the store writes what it would change and puts it back like any write.
"""
from __future__ import annotations

import ctypes
import errno
import logging
import math
import multiprocessing as mp
import os
import queue
import resource
import select
import signal
import threading
import time
from collections.abc import Mapping
from typing import NoReturn

import pyoxigraph as ox

from urdfkb.kb_server.results import ResultLimits, ResultTooLarge
from urdfkb.kb_server.sparql import (NotAcceptable, QueryError, QueryTimeout, Result, graph_dump, graph_dumps, put_graph,
                              run_query, run_update)
from urdfkb.pipeline.errors import UrdfkbError
from urdfkb.pipeline.reading.sandbox import add_rules

Changes = dict[str, tuple[bytes | None, bytes | None]]


class WorkerCrashed(UrdfkbError, RuntimeError):
    """A worker process died while evaluating an operation (a bug in the engine); it was replaced."""

    status = 500


class QueryOutOfMemory(UrdfkbError, MemoryError):
    """The operation needed more memory than a query worker may use; its worker was replaced."""

    status = 503


NO_NETWORK = ("socket", "socketpair", "io_uring_setup")  # refused to workers (EACCES): nothing to connect with
_ANSWERED = (QueryError, NotAcceptable, ResultTooLarge)  # errors a worker sends back by name, staying up
_ERRORS = {e.__name__: e for e in _ANSWERED}


def _die_with_parent() -> None:
    """On Linux, have the kernel end this worker when the server process ends: a server killed while
    its queue was writing a graph leaves a half message that no read would ever finish."""
    try:
        ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGKILL)  # 1 = PR_SET_PDEATHSIG
    except (OSError, AttributeError):  # not Linux: the parent check in the loop still applies
        pass


def _confine(memory: int) -> None:
    """No sockets (so no network, whatever the engine is asked) and at most `memory` bytes of address space.
    Without libseccomp the worker runs unconfined and says so: the lexical checks still refuse SERVICE and LOAD."""
    resource.setrlimit(resource.RLIMIT_AS, (memory, memory))
    try:
        import pyseccomp as seccomp
        rules = seccomp.SyscallFilter(defaction=seccomp.ALLOW)
        add_rules(rules, seccomp.ERRNO(errno.EACCES), NO_NETWORK)
        rules.load()
    except (ImportError, OSError, TypeError, RuntimeError) as e:  # pyseccomp raises on import without libseccomp
        logging.getLogger(__name__).warning("SPARQL workers are not network-confined (libseccomp: %s)", e)


def _serve(inbox, requests, replies, parent: int, limits: ResultLimits) -> None:
    """A worker's loop. `inbox` brings (seq, {graph: data}) replacements in order; `requests` brings
    (seq, op, args): the op runs once every replacement up to seq is applied, its answer goes to `replies`
    (a query's as ("result", (kind, media type)) then its serialised body as raw bytes, untouched).
    `parent` is the server's pid, passed in: a worker that starts after its server was killed sees
    another parent from its first instruction on (and would wait forever on the half message)."""
    _die_with_parent()
    _confine(limits.memory)
    store, applied = ox.Store(), 0
    if os.getppid() != parent:  # the server went before the kernel was told
        return

    def apply(block: bool) -> None:
        nonlocal applied
        seq, graphs = inbox.get(timeout=0.5) if block else inbox.get_nowait()
        for graph, data in graphs.items():
            put_graph(store, graph, data)
        applied = seq

    while True:
        try:
            while True:
                apply(block=False)
        except queue.Empty:
            pass
        if not requests.poll(0.05):
            if os.getppid() != parent:  # the server is gone (even by kill -9): so is this worker
                return
            continue
        seq, op, args = requests.recv()
        while applied < seq:
            try:
                apply(block=True)
            except queue.Empty:  # waiting for a replacement: never for a server that is gone
                if os.getppid() != parent:
                    return
        try:
            if op == "query":
                text, accept, default_graphs, named_graphs = args
                result = run_query(store, text, accept, default_graphs, named_graphs, limits)
                replies.send(("result", (result.kind, result.media_type)))
                replies.send_bytes(result.body)
            else:
                replies.send(("ok", run_update(store, *args)))
        except _ANSWERED as e:
            replies.send((type(e).__name__, str(e)))
        except MemoryError:  # in Python code; the engine's own allocations abort the process (SIGABRT)
            return


class _Worker:
    """A worker process: graph replacements go through a queue (never blocking the writer), each
    operation through a pipe, carrying the sequence number of the last replacement it must see."""

    def __init__(self, ctx, graphs: Mapping[str, bytes], limits: ResultLimits):
        self.inbox, self.seq, self.memory = ctx.Queue(), 0, limits.memory
        self.requests, requests = ctx.Pipe(duplex=False)[::-1]
        self.replies, replies = ctx.Pipe(duplex=False)
        self.proc = ctx.Process(target=_serve, args=(self.inbox, requests, replies, os.getpid(), limits), daemon=True,
                                name="urdfkb-sparql")
        self.proc.start()
        requests.close()
        replies.close()
        self.ready = select.poll()  # the reply pipe and the process's sentinel, registered once
        for fd in (self.replies.fileno(), self.proc.sentinel):
            self.ready.register(fd, select.POLLIN)
        self.put(dict(graphs))

    def put(self, graphs: dict) -> None:
        """Queue graph replacements (callers hold the index guard, so seq only grows)."""
        self.seq += 1
        self.inbox.put((self.seq, graphs))

    def call(self, op: str, args: tuple, deadline: float):
        self.requests.send((self.seq, op, args))
        if not self.ready.poll(max(math.ceil(1000 * (deadline - time.monotonic())), 0)):
            raise QueryTimeout("operation stopped after its timeout")
        try:
            status, value = self.replies.recv() if self.replies.poll() else self._died()
            if status == "result":
                kind, media_type = value
                return Result(kind, media_type, self.replies.recv_bytes())
        except EOFError:  # the worker died; its end of the pipe closed with it
            status, value = self._died()
        if status != "ok":
            raise _ERRORS[status](value)
        return value

    def _died(self) -> NoReturn:
        """Raise what the worker's death says: out of its memory (the engine's allocation failed and aborted,
        or Python's raised MemoryError and the loop returned), else a crash."""
        self.proc.join(1)
        if self.proc.exitcode in (-signal.SIGABRT, 0):
            raise QueryOutOfMemory(f"the operation needed more than the {self.memory // 2**20:,} MiB a query "
                                   "worker may use (--query-memory): narrow it, or add a LIMIT")
        raise WorkerCrashed("the query engine's worker process crashed on this operation (it was replaced)")

    def alive(self) -> bool:
        return self.proc.is_alive()

    def kill(self) -> None:
        self.proc.kill()
        self.proc.join(5)
        self.inbox.cancel_join_thread()
        self.inbox.close()
        self.requests.close()
        self.replies.close()


class Index:
    """The master store plus `workers` query processes (0: evaluate in this process, no deadline);
    every answer is bounded by `limits`."""

    def __init__(self, graphs: Mapping[str, bytes], workers: int, limits: ResultLimits):
        self.master, self.limits = ox.Store(), limits
        for graph, data in graphs.items():
            put_graph(self.master, graph, data)
        self._ctx = mp.get_context("spawn")
        self._guard = threading.Lock()  # master, worker list, broadcasts
        self._workers: list[_Worker] = []
        self._size = workers  # the list may be short while a worker is replaced: never evaluate in-process then
        self._idle: queue.Queue[_Worker] = queue.Queue()
        for _ in range(workers):
            self._spawn()

    def _spawn(self) -> None:
        with self._guard:
            worker = _Worker(self._ctx, graph_dumps(self.master), self.limits)
            self._workers.append(worker)
        self._idle.put(worker)

    def _retire(self, worker: _Worker) -> None:
        with self._guard:
            self._workers.remove(worker)
        worker.kill()
        self._spawn()

    def _call(self, op: str, args: tuple, timeout: float):
        """Run `op` on a free worker within `timeout` (waiting for one included); the worker goes back to
        the pool (an update's changes undone on it first), or is replaced if it overran or died."""
        deadline = time.monotonic() + timeout
        try:
            worker = self._idle.get(timeout=timeout)
        except queue.Empty:
            raise QueryTimeout(f"no query worker free within the {timeout:g} s timeout") from None
        try:
            value = worker.call(op, args, deadline)
        except _ANSWERED:
            self._idle.put(worker)
            raise
        except QueryTimeout:
            self._retire(worker)
            raise QueryTimeout(f"stopped after its {timeout:g} s timeout") from None
        except BaseException:
            self._retire(worker)
            raise
        if not worker.alive():  # crashed after answering: its replacement starts from the master
            self._retire(worker)
            return value
        if op == "update" and value:  # back to what the master holds, in order with the writes
            with self._guard:
                worker.put({g: before for g, (before, _) in value.items()})
        self._idle.put(worker)
        return value

    def query(self, text: str, accept: str | None, timeout: float,
              default_graphs: list[str] | None = None, named_graphs: list[str] | None = None) -> Result:
        """Evaluate a query on a free worker; QueryError, NotAcceptable, ResultTooLarge past the index's
        limits, or QueryTimeout past `timeout`."""
        args = (text, accept, default_graphs, named_graphs)
        return self._call("query", args, timeout) if self._size else run_query(self.master, *args, limits=self.limits)

    def update(self, text: str, timeout: float) -> Changes:
        """Evaluate an update on one replica (the master without workers) and undo it there: returns
        {graph: (before, after)} for the graphs it would change, for the store to write and `put` back."""
        if not self._size:
            with self._guard:
                changes = run_update(self.master, text)
                for g, (before, _) in changes.items():
                    put_graph(self.master, g, before)
            return changes
        return self._call("update", (text,), timeout)

    def graph(self, graph: str) -> bytes | None:
        """One graph's N-Triples as last committed (None: no such graph), read from the master under the index's own
        guard: what the store wrote last, without waiting for a write the store is making."""
        with self._guard:
            return graph_dump(self.master, graph)

    def put(self, graphs: Mapping[str, bytes | None]) -> None:
        """Replace graphs (None drops one) in the master and every worker, in order with other writes."""
        if not graphs:
            return
        with self._guard:
            for g, data in graphs.items():
                put_graph(self.master, g, data)
            for w in self._workers:
                w.put(dict(graphs))

    def close(self) -> None:
        with self._guard:
            workers, self._workers = self._workers, []
        for w in workers:
            w.kill()
