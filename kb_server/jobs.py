"""Populate jobs: the pipeline runs in a worker outside the store lock, then one transaction stores it.

A job's source is an ingested tree, or a loader run in the job itself (a xacro upload: its
expansion is code, so it costs its own job and never a request thread).
Job states: queued -> running -> succeeded | failed | mirror_failed. `mirror_failed` means the
robot *was* stored and is served locally, but the remote store (--remote-store) was not updated;
the reason is in `errors`; re-populating the robot, or restarting the server (mirror_all), retries. A failed job leaves the
store as it was. Jobs for the same robot run one after the other (a lock per robot name).
At most `max_queued` jobs wait for a worker (QueueFull beyond), and finished jobs are forgotten
after `keep_seconds` or when more than `keep` have finished since.

Pipelines run on one model thread (ModelWorker), one at a time in the order they were queued, and
that thread keeps the last embedded model loaded: a second populate with the same model skips the
load, and two jobs never hold two models. Between runs the model forgets everything the previous run
left (its KV cache, its counters), so a job's answers are those of a freshly loaded model.
"""
from __future__ import annotations

import logging
import queue
import threading
import time
import traceback
import uuid
from collections import OrderedDict
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import Callable, TypeVar

from urdfkb.kb_server.errors import TooManyRequests
from urdfkb.kb_server.remote import RemoteError, RemoteStore
from urdfkb.kb_server.store import RobotEntry, RobotNameError, Store, check_robot_name
from urdfkb.kb_server.text import cut
from urdfkb.pipeline.abstraction.components import Abstraction
from urdfkb.pipeline.errors import UrdfkbError
from urdfkb.pipeline.llm.base import Backend
from urdfkb.pipeline.runner import Progress, Settings, make_backend, run
from urdfkb.pipeline.reading.tree import KinematicTree
from urdfkb.settings import JOB_THREADS, KEEP_JOB_SECONDS, KEEP_JOBS, MAX_QUEUED_JOBS, QUEUE_RETRY_AFTER

log = logging.getLogger(__name__)

Runner = Callable[[KinematicTree, Settings, Progress], Abstraction]
Source = KinematicTree | Callable[[], KinematicTree]
T = TypeVar("T")


class QueueFull(TooManyRequests):
    """Too many populate jobs are waiting for a worker; retry after `retry_after` seconds."""

    status = 429


class ModelWorker:
    """One thread that runs pipelines in the order they are queued, keeping one embedded model warm.

    Calling it (the Runner signature) queues the run and waits for its result, so a job's thread
    blocks while the runs queued before it finish. The warm model is the llama.cpp backend the last
    run used; a run with another model file closes it before loading its own. A run on a model
    server (`llm_url`) or answered from the result cache loads nothing. `make` builds a backend from
    settings (runner.make_backend; tests pass another).
    """

    def __init__(self, make: Callable[[Settings], Backend] = make_backend):
        self._make = make
        self._queue: queue.Queue = queue.Queue()
        self._thread: threading.Thread | None = None
        self._start = threading.Lock()
        self._backend: Backend | None = None
        self._model: str | None = None  # the model file the warm backend runs ("" for the default)
        self.loads = 0  # models loaded so far

    def __call__(self, tree: KinematicTree, settings: Settings, progress: Progress) -> Abstraction:
        return self._submit(lambda: self._run(tree, settings, progress))

    def release(self) -> None:
        """Close the warm model once the runs queued before this call are done."""
        self._submit(self._close)

    def _submit(self, task: Callable[[], object]):
        """Run `task` on the model thread after everything queued before it; its result or exception."""
        done: Future = Future()
        self._queue.put((task, done))
        with self._start:
            if self._thread is None or not self._thread.is_alive():
                self._thread = threading.Thread(target=self._serve, name="urdfkb-model", daemon=True)
                self._thread.start()
        return done.result()

    def _serve(self) -> None:
        while True:
            task, done = self._queue.get()
            try:
                done.set_result(task())
            except BaseException as e:  # raised in the thread that queued the task
                done.set_exception(e)

    def _run(self, tree: KinematicTree, settings: Settings, progress: Progress) -> Abstraction:
        if settings.structure_only or settings.llm_url:
            return run(tree, settings, progress=progress)  # no embedded model
        return run(tree, settings, progress=progress, backends=self._warm)

    def use(self, task: Callable[[Backend], T]) -> T:
        """task(the default model) on the model thread, after the runs queued before it; the model keeps its
        state (questions in words reuse their prompt states)."""
        return self._submit(lambda: task(self._loaded(Settings())))

    def _warm(self, settings: Settings) -> Backend:
        """The backend for `settings`' model file, loaded unless it is the warm one, as a fresh one answers."""
        backend = self._loaded(settings)
        backend.fresh()
        return backend

    def _loaded(self, settings: Settings) -> Backend:
        """The backend for `settings`' model file, loaded unless it is the warm one."""
        model = settings.model or ""
        if self._backend is not None and self._model != model:
            self._close()
        if self._backend is None:
            self._backend, self._model = self._make(settings), model
            self.loads += 1
        return self._backend

    def _close(self) -> None:
        if self._backend is not None:
            backend, self._backend, self._model = self._backend, None, None
            backend.close()


pipeline_runner = ModelWorker()  # the production runner: one model thread for the whole process


@dataclass
class Job:
    """One populate request and how far it got."""

    id: str
    robot: str | None  # None until a loaded source names it
    state: str = "queued"
    stage: str = "queued"
    done: int = 0
    total: int = 0
    errors: list[str] = field(default_factory=list)
    created: float = field(default_factory=time.time)
    started: float | None = None
    finished: float | None = None
    ontology: str | None = None
    corrections: dict | None = None  # reviewers' corrections applied / no longer fitting (review.Report)
    finished_event: threading.Event = field(default_factory=threading.Event, repr=False)

    def to_dict(self) -> dict:
        return {"id": self.id, "robot": self.robot, "state": self.state, "stage": self.stage,
                "progress": {"done": self.done, "total": self.total}, "errors": list(self.errors),
                "ontology": self.ontology, "corrections": self.corrections, "created": self.created, "started": self.started, "finished": self.finished}

    def wait(self, timeout: float | None) -> bool:
        return self.finished_event.wait(timeout)

    def error(self, message: str) -> None:
        """Keep `message` with the job, cut to MAX_ERROR characters (kept for GET /jobs/<id>, logged)."""
        self.errors.append(cut(message))


class JobManager:
    """Runs populate jobs on a small thread pool; remembers unfinished jobs and recently finished ones."""

    def __init__(self, store: Store, runner: Runner = pipeline_runner, remote: RemoteStore | None = None,
                 workers: int = JOB_THREADS, max_queued: int = MAX_QUEUED_JOBS, keep: int = KEEP_JOBS,
                 keep_seconds: float = KEEP_JOB_SECONDS):
        self.store = store
        self.runner = runner
        self.remote = remote
        self.max_queued, self.keep, self.keep_seconds = max_queued, keep, keep_seconds
        self.retention = (f"finished jobs are kept for {keep_seconds / 60:g} minutes, "
                          f"and only the last {keep} of them")
        self._pool = ThreadPoolExecutor(max_workers=workers, thread_name_prefix="urdfkb-job")
        self._jobs: OrderedDict[str, Job] = OrderedDict()
        self._robot_locks: dict[str, threading.Lock] = {}
        self._guard = threading.Lock()

    def submit(self, source: Source, robot: str | None, settings: Settings) -> Job:
        """Queue populating `robot` (None: the name the loaded robot gives) from an ingested tree or
        a loader the job runs first; returns at once (QueueFull if full)."""
        job = Job(uuid.uuid4().hex, robot)
        with self._guard:
            self._expire()
            if sum(j.state == "queued" for j in self._jobs.values()) >= self.max_queued:
                raise QueueFull(f"{self.max_queued} populate jobs are already queued; retry later", QUEUE_RETRY_AFTER)
            self._jobs[job.id] = job
        self._pool.submit(self._run, job, source, settings)
        return job

    def get(self, job_id: str) -> Job | None:
        with self._guard:
            self._expire()
            return self._jobs.get(job_id)

    def _expire(self) -> None:
        """Forget finished jobs older than keep_seconds, and all but the newest `keep` finished (under _guard)."""
        ended = {j.id: j.finished for j in self._jobs.values() if j.finished is not None}
        finished = sorted(ended, key=ended.__getitem__)
        cutoff = time.time() - self.keep_seconds
        for i, job_id in enumerate(finished):
            if ended[job_id] < cutoff or i < len(finished) - self.keep:
                del self._jobs[job_id]

    def delete_robot(self, robot: str) -> tuple[RobotEntry | None, str | None]:
        """Delete a robot (after any job on it) and its remote graph.

        Returns (entry or None if unknown, the mirror error message or None)."""
        with self._robot_lock(robot):
            entry = self.store.delete_robot(robot)
            if entry is None or not self.remote:
                return entry, None
            try:
                self.remote.delete_graph(entry.ontology_iri)
            except RemoteError as e:
                return entry, f"deleted locally, but deleting the remote graph failed: {e}"
            return entry, None

    def mirror_all(self) -> Future | None:
        """Push every stored robot to the remote store in the background (at startup: mirrors robots
        stored before the remote was configured and repairs earlier mirror failures)."""
        return self._pool.submit(self._mirror_all) if self.remote else None

    def _mirror_all(self) -> None:
        if (remote := self.remote) is None:
            raise RuntimeError("mirroring without a remote store")
        for entry in self.store.robots():
            with self._robot_lock(entry.name):
                graph = self.store.graph(entry.name)
                if graph is None:  # deleted meanwhile
                    continue
                try:
                    remote.put_graph(entry.ontology_iri, graph)
                except RemoteError as e:
                    log.warning("mirroring %s failed: %s", entry.name, cut(str(e)))

    def shutdown(self) -> None:
        self._pool.shutdown(wait=True, cancel_futures=True)
        if isinstance(self.runner, ModelWorker):
            self.runner.release()

    def _robot_lock(self, robot: str) -> threading.Lock:
        with self._guard:
            return self._robot_locks.setdefault(robot, threading.Lock())

    def _run(self, job: Job, source: Source, settings: Settings) -> None:
        def progress(stage: str, done: int, total: int) -> None:
            job.stage, job.done, job.total = stage, done, total

        try:
            job.state, job.started = "running", time.time()
            tree = source if isinstance(source, KinematicTree) else self._load(job, source)
            if (robot := job.robot) is None:
                raise RuntimeError(f"job {job.id} has no robot name after loading its source")
            with self._robot_lock(robot):
                job.stage = "pipeline"
                abstraction = self.runner(tree, settings, progress)
                progress("store", 0, 1)
                entry = self.store.replace_robot(robot, tree, abstraction)
                job.ontology, job.corrections = entry.ontology_iri, entry.corrections
                progress("store", 1, 1)
                job.state = self._mirror(job, robot, entry.ontology_iri)
        except UrdfkbError as e:
            job.state = "failed"
            job.error(str(e))
        except Exception as e:  # anything else is a bug: keep serving, report it in the job
            log.error("populate job %s for %s failed:\n%s", job.id, job.robot, _traceback(e))
            job.state = "failed"
            job.error(f"internal error: {type(e).__name__}: {e}")
        finally:
            job.finished = time.time()
            # logged before waiters are woken: one that reads the log after the job ends finds the line
            log.info("populate %s (job %s): %s %s", job.robot, job.id, job.state, "; ".join(job.errors))
            job.finished_event.set()

    @staticmethod
    def _load(job: Job, load: Callable[[], KinematicTree]) -> KinematicTree:
        job.stage = "load"
        tree = load()
        if job.robot is None:
            try:
                job.robot = check_robot_name(tree.robot_name)
            except RobotNameError as e:
                raise RobotNameError(f"{e}: pass ?name=...") from None
        return tree

    def _mirror(self, job: Job, robot: str, ontology: str) -> str:
        """Copy the robot's graph (its ontology `ontology`) to the remote store, under the robot's lock."""
        if not self.remote:
            return "succeeded"
        job.stage = "mirror"
        if (graph := self.store.graph(robot)) is None:
            raise RuntimeError(f"{robot} left the store while its job held its lock")
        try:
            self.remote.put_graph(ontology, graph)
        except RemoteError as e:
            job.error(f"stored locally, but mirroring to the remote store failed: {e}")
            return "mirror_failed"
        return "succeeded"


def _traceback(e: Exception) -> str:
    """A bug's traceback for the log, its message cut (MAX_ERROR) as the job's error is."""
    return "".join(traceback.format_tb(e.__traceback__)) + cut(f"{type(e).__name__}: {e}")
