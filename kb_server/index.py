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

Operations are submitted with a callback (`submit`): the caller's thread hands the operation to a free
worker (or queues it), and one answering thread waits on every worker's reply pipe at once, reads each
answer as one message, enforces the deadlines and calls back. No thread waits per operation, so the
HTTP server's I/O thread can submit a query and go on serving (kb_server/sparql_front.py); `query` and
`update` wait for the callback.

Answers are kept in a result cache (kb_server/result_cache.py) until the next write: `put`, which every
write of the store goes through, moves the cache to its next generation once the master and every worker
have the write queued, and a query's answer is kept only under the generation it was submitted in.
"""
from __future__ import annotations

import ctypes
import errno
import logging
import math
import multiprocessing as mp
import os
import pickle
import queue
import resource
import selectors
import signal
import threading
import time
from collections import deque
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, NoReturn

import pyoxigraph as ox

from urdfkb.kb_server.result_cache import ResultCache, cache_key
from urdfkb.kb_server.results import ResultLimits, ResultTooLarge
from urdfkb.kb_server.sparql import (NotAcceptable, QueryError, QueryTimeout, Result, graph_dump, graph_dumps, put_graph,
                              run_query, run_update)
from urdfkb.pipeline.errors import UrdfkbError
from urdfkb.pipeline.reading.sandbox import add_rules
from urdfkb.settings import RESULT_CACHE

Changes = dict[str, tuple[bytes | None, bytes | None]]
Done = Callable[[Any, BaseException | None], None]  # (value, None) or (None, the error)


class WorkerCrashed(UrdfkbError, RuntimeError):
    """A worker process died while evaluating an operation (a bug in the engine); it was replaced."""

    status = 500


class QueryOutOfMemory(UrdfkbError, MemoryError):
    """The operation needed more memory than a query worker may use; its worker was replaced."""

    status = 503


class IndexClosed(UrdfkbError, RuntimeError):
    """The server is stopping: its query workers are gone."""

    status = 503


NO_NETWORK = ("socket", "socketpair", "io_uring_setup")  # refused to workers (EACCES): nothing to connect with
_ANSWERED = (QueryError, NotAcceptable, ResultTooLarge)  # errors a worker sends back by name, staying up
_ERRORS = {e.__name__: e for e in _ANSWERED}
_HEAD = 4  # bytes of a reply's header length


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


def _reply(replies, status: str, value: object, body: bytes = b"") -> None:
    """One message: the pickled (status, value), its length first, then a query's serialised answer untouched."""
    head = pickle.dumps((status, value))
    replies.send_bytes(len(head).to_bytes(_HEAD, "big") + head + body)


def _serve(inbox, requests, replies, parent: int, limits: ResultLimits) -> None:
    """A worker's loop. `inbox` brings (seq, {graph: data}) replacements in order; `requests` brings
    (seq, op, args): the op runs once every replacement up to seq is applied, its answer goes to `replies`
    as one message (_reply: a query's as ("result", (kind, media type)) and its body).
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
                _reply(replies, "result", (result.kind, result.media_type), result.body)
            else:
                _reply(replies, "ok", run_update(store, *args))
        except _ANSWERED as e:
            _reply(replies, type(e).__name__, str(e))
        except MemoryError:  # in Python code; the engine's own allocations abort the process (SIGABRT)
            return


@dataclass
class _Job:
    """An operation submitted: what to run, until when, and whom to tell."""

    op: str
    args: tuple
    timeout: float
    deadline: float
    done: Done


def _tell(job: _Job, value: Any, error: BaseException | None) -> None:
    """Call the job's callback; what it raises is logged, never the end of the answering thread."""
    try:
        job.done(value, error)
    except Exception:
        logging.getLogger(__name__).exception("answering a SPARQL %s", job.op)


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
        self.job: _Job | None = None  # the operation it is answering
        self.put(dict(graphs))

    def put(self, graphs: dict) -> None:
        """Queue graph replacements (callers hold the index guard, so seq only grows)."""
        self.seq += 1
        self.inbox.put((self.seq, graphs))

    def send(self, job: _Job) -> None:
        """Hand `job` over; a worker that died meanwhile is noticed by its sentinel, not here."""
        self.job = job
        try:
            self.requests.send((self.seq, job.op, job.args))
        except OSError:
            pass

    def answer(self):
        """The value of the answer waiting in the reply pipe (or raise its error, or the worker's death)."""
        try:
            data = self.replies.recv_bytes() if self.replies.poll() else self._died()
        except EOFError:  # the worker died; its end of the pipe closed with it
            self._died()
        size = _HEAD + int.from_bytes(data[:_HEAD], "big")
        status, value = pickle.loads(data[_HEAD:size])
        if status == "result":
            kind, media_type = value
            return Result(kind, media_type, data[size:])
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
    every answer is bounded by `limits`, and answers are kept in a cache of `cache_bytes` (0: none)."""

    def __init__(self, graphs: Mapping[str, bytes], workers: int, limits: ResultLimits, cache_bytes: int = RESULT_CACHE):
        self.master, self.limits = ox.Store(), limits
        self.cache = ResultCache(cache_bytes)
        for graph, data in graphs.items():
            put_graph(self.master, graph, data)
        self._ctx = mp.get_context("spawn")
        self._guard = threading.Lock()  # master, worker list, broadcasts
        self._workers: list[_Worker] = []
        self.workers = workers  # the list may be short while a worker is replaced: never evaluate in-process then
        self._pool = threading.Lock()  # the free workers, the waiting jobs, the busy workers, the arrivals
        self._free: list[_Worker] = []
        self._waiting: deque[_Job] = deque()
        self._busy: set[_Worker] = set()
        self._arrived: list[_Worker] = []  # replacements, for the answering thread to watch
        self._closed = False
        self._planned = math.inf  # the deadline the answering thread's wait ends at
        self._selector = selectors.DefaultSelector()
        self._wake_read, self._wake_write = os.pipe()
        os.set_blocking(self._wake_read, False)
        os.set_blocking(self._wake_write, False)
        self._selector.register(self._wake_read, selectors.EVENT_READ)
        for _ in range(workers):
            self._watch(self._spawn())
        self._thread = threading.Thread(target=self._answering, name="urdfkb-sparql-answers", daemon=True)
        if workers:
            self._thread.start()

    # --- submitting ----------------------------------------------------------------------------

    def submit(self, op: str, args: tuple, timeout: float, done: Done) -> None:
        """Run `op` on a free worker within `timeout` (waiting for one included); `done(value, error)` is called
        from the answering thread, never from this call. The worker goes back to the pool (an update's changes
        undone on it first), or is replaced if it overran or died. Needs workers."""
        job = _Job(op, args, timeout, time.monotonic() + timeout, done)
        with self._pool:
            if self._closed:
                raise IndexClosed("the SPARQL index is closed")
            worker = self._free.pop() if self._free else None
            if worker is None:
                self._waiting.append(job)
            else:
                self._busy.add(worker)
                worker.job = job
            wake = job.deadline < self._planned
        if worker is not None:
            worker.send(job)
        if wake:
            self._wake()

    def _call(self, op: str, args: tuple, timeout: float):
        """`submit`, waiting for the answer."""
        answered, out = threading.Event(), []

        def done(value, error) -> None:
            out.append((value, error))
            answered.set()
        self.submit(op, args, timeout, done)
        answered.wait()
        value, error = out[0]
        if error is not None:
            raise error
        return value

    def cached(self, text: str, accept: str | None, default_graphs: list[str] | None,
               named_graphs: list[str] | None) -> Result | None:
        """The answer the result cache holds for this query, as of the last write; None if it holds none."""
        k = cache_key(text, accept, default_graphs, named_graphs) if self.cache.capacity else None
        return None if k is None else self.cache.get(k)

    def _keeper(self, text: str, accept: str | None, default_graphs: list[str] | None,
                named_graphs: list[str] | None) -> Callable[[Result], None]:
        """What keeps this query's answer in the result cache: under the generation of the data now, before the
        query is submitted, so that an answer a write overtook is dropped."""
        k = cache_key(text, accept, default_graphs, named_graphs) if self.cache.capacity else None
        generation = self.cache.generation
        return (lambda result: None) if k is None else (lambda result: self.cache.put(k, generation, result))

    def submit_query(self, text: str, accept: str | None, timeout: float, default_graphs: list[str] | None,
                     named_graphs: list[str] | None, done: Done) -> None:
        """`query` answered through `done(Result or None, error or None)` (see `submit`), evaluated by a worker
        whatever the cache holds (look there first with `cached`); a successful answer is kept. Needs workers."""
        keep = self._keeper(text, accept, default_graphs, named_graphs)

        def kept(value: Any, error: BaseException | None) -> None:
            if error is None:
                keep(value)
            done(value, error)
        self.submit("query", (text, accept, default_graphs, named_graphs), timeout, kept)

    def query(self, text: str, accept: str | None, timeout: float, default_graphs: list[str] | None = None,
              named_graphs: list[str] | None = None, fresh: bool = False) -> Result:
        """The answer the result cache holds for this query (unless `fresh`: evaluated all the same), else
        evaluate it on a free worker and keep its answer; QueryError, NotAcceptable, ResultTooLarge past the
        index's limits, or QueryTimeout past `timeout`."""
        args = (text, accept, default_graphs, named_graphs)
        if not fresh and (kept := self.cached(*args)) is not None:
            return kept
        keep = self._keeper(*args)
        result = self._call("query", args, timeout) if self.workers else run_query(self.master, *args, limits=self.limits)
        keep(result)
        return result

    def update(self, text: str, timeout: float) -> Changes:
        """Evaluate an update on one replica (the master without workers) and undo it there: returns
        {graph: (before, after)} for the graphs it would change, for the store to write and `put` back."""
        if not self.workers:
            with self._guard:
                changes = run_update(self.master, text)
                for g, (before, _) in changes.items():
                    put_graph(self.master, g, before)
                if changes:  # a query evaluated meanwhile may have read them
                    self.cache.invalidate()
            return changes
        return self._call("update", (text,), timeout)

    # --- the answering thread ----------------------------------------------------------------------

    def _wake(self) -> None:
        try:
            os.write(self._wake_write, b"\0")
        except BlockingIOError:  # wakes already pending
            pass

    def _answering(self) -> None:
        """Wait on every worker's reply pipe and death at once, and on the next deadline; answer what comes."""
        while True:
            with self._pool:
                if self._closed:
                    return
                arrived, self._arrived = self._arrived, []
                deadlines = [w.job.deadline for w in self._busy if w.job] + [j.deadline for j in self._waiting]
                self._planned = min(deadlines, default=math.inf)
            for worker in arrived:
                self._watch(worker)
            wait = None if self._planned == math.inf else max(self._planned - time.monotonic(), 0.0)
            for key, _ in self._selector.select(wait):
                if key.data is None:
                    while True:
                        try:
                            if not os.read(self._wake_read, 512):
                                break
                        except BlockingIOError:
                            break
                elif key.data in self._workers:  # not replaced by an event before this one
                    self._answered(key.data)
            self._expire(time.monotonic())

    def _answered(self, worker: _Worker) -> None:
        """The worker's reply pipe or sentinel is ready: its answer, or its death."""
        with self._pool:
            job, worker.job = worker.job, None
            self._busy.discard(worker)
        if job is None:  # a free worker died
            self._replace(worker)
            return
        value, error = None, None
        try:
            value = worker.answer()
        except (*_ANSWERED, QueryOutOfMemory, WorkerCrashed) as e:
            error = e
        if error is None and not worker.alive() or isinstance(error, (QueryOutOfMemory, WorkerCrashed)):
            self._replace(worker)  # crashed after answering: its replacement starts from the master
        else:
            if job.op == "update" and value:  # back to what the master holds, in order with the writes
                with self._guard:
                    worker.put({g: before for g, (before, _) in value.items()})
            self._release(worker)
        _tell(job, value, error)

    def _release(self, worker: _Worker) -> None:
        """A worker is free: it takes the next waiting job, or joins the free ones."""
        with self._pool:
            job = self._waiting.popleft() if self._waiting else None
            if job is None:
                self._free.append(worker)
            else:
                self._busy.add(worker)
                worker.job = job
        if job is not None:
            worker.send(job)

    def _expire(self, now: float) -> None:
        """Refuse the jobs that waited past their deadline for a worker; stop and replace the workers past theirs."""
        with self._pool:
            late = [j for j in self._waiting if j.deadline <= now]
            for job in late:
                self._waiting.remove(job)
            overdue = [w for w in self._busy if w.job and w.job.deadline <= now]
            for worker in overdue:
                self._busy.discard(worker)
        for job in late:
            _tell(job, None, QueryTimeout(f"no query worker free within the {job.timeout:g} s timeout"))
        for worker in overdue:
            stopped, worker.job = worker.job, None
            self._replace(worker)
            assert stopped is not None
            _tell(stopped, None, QueryTimeout(f"stopped after its {stopped.timeout:g} s timeout"))

    # --- workers -----------------------------------------------------------------------------------

    def _spawn(self) -> _Worker:
        with self._guard:
            worker = _Worker(self._ctx, graph_dumps(self.master), self.limits)
            self._workers.append(worker)
        return worker

    def _watch(self, worker: _Worker) -> None:
        """(In the answering thread, or before it starts) watch a new worker's replies and death; it is free."""
        self._selector.register(worker.replies.fileno(), selectors.EVENT_READ, worker)
        self._selector.register(worker.proc.sentinel, selectors.EVENT_READ, worker)
        self._release(worker)

    def _replace(self, worker: _Worker) -> None:
        """(In the answering thread) stop watching `worker`; kill it and start its replacement in the background."""
        self._selector.unregister(worker.replies.fileno())
        self._selector.unregister(worker.proc.sentinel)
        with self._guard:
            self._workers.remove(worker)

        def replace() -> None:
            worker.kill()
            with self._pool:
                if self._closed:
                    return
            new = self._spawn()
            with self._pool:
                closed = self._closed
                if not closed:
                    self._arrived.append(new)
            if closed:
                new.kill()
            else:
                self._wake()
        threading.Thread(target=replace, name="urdfkb-sparql-replace", daemon=True).start()

    # --- graphs --------------------------------------------------------------------------------------

    def graph(self, graph: str) -> bytes | None:
        """One graph's N-Triples as last committed (None: no such graph), read from the master under the index's own
        guard: what the store wrote last, without waiting for a write the store is making."""
        with self._guard:
            return graph_dump(self.master, graph)

    def put(self, graphs: Mapping[str, bytes | None]) -> None:
        """Replace graphs (None drops one) in the master and every worker, in order with other writes; then no
        answer kept before is given again (a query submitted from now on is evaluated after the replacement)."""
        if not graphs:
            return
        with self._guard:
            for g, data in graphs.items():
                put_graph(self.master, g, data)
            for w in self._workers:
                w.put(dict(graphs))
            self.cache.invalidate()

    def close(self) -> None:
        """Stop the workers; operations still waiting or running fail with IndexClosed."""
        with self._pool:
            self._closed = True
            jobs = [*self._waiting, *(w.job for w in self._busy if w.job)]
            self._waiting.clear()
        self._wake()
        if self._thread.is_alive():
            self._thread.join(5)
        with self._guard:
            workers, self._workers = self._workers, []
        for w in workers:
            w.kill()
        for job in jobs:
            _tell(job, None, IndexClosed("the SPARQL index was closed before answering"))
        self._selector.close()
        os.close(self._wake_read)
        os.close(self._wake_write)
