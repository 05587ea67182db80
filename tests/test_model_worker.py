"""The server's model worker: one thread runs the pipelines in order, with one warm model, fresh for each run."""
from __future__ import annotations

import threading
import time

import pytest

from tests.head_robot import HEAD, perfect
from urdfkb.kb_server.jobs import JobManager, ModelWorker
from urdfkb.pipeline.errors import BackendError
from urdfkb.pipeline.reading.ingest import load_urdf
from urdfkb.pipeline.llm.scripted import ScriptedBackend
from urdfkb.pipeline.runner import Settings, run

class Models:
    """A stand-in for runner.make_backend: scripted backends, counting what is loaded and open at once."""

    def __init__(self, rule=perfect):
        self.rule, self.made, self.closed, self.open, self.most_open = rule, [], 0, 0, 0
        self.guard = threading.Lock()

    def __call__(self, settings: Settings) -> ScriptedBackend:
        models = self

        class Counted(ScriptedBackend):
            def close(self) -> None:
                with models.guard:
                    models.closed += 1
                    models.open -= 1

        with self.guard:
            self.open += 1
            self.most_open = max(self.most_open, self.open)
        backend = Counted(self.rule, name=f"scripted:{settings.model}")
        self.made.append(backend)
        return backend


def no_progress(stage, done, total):
    pass


@pytest.fixture
def toy():
    return load_urdf(HEAD.encode())


def test_a_second_run_skips_the_load_and_answers_as_a_fresh_backend(toy):
    models = Models()
    worker = ModelWorker(models)
    try:
        settings = Settings(use_cache=False)
        first = worker(toy, settings, no_progress)
        second = worker(toy, settings, no_progress)
    finally:
        worker.release()
    alone = run(toy, settings, backend=ScriptedBackend(perfect, name="scripted:None"))
    assert worker.loads == 1 and len(models.made) == 1 and models.closed == 1
    assert first.components == second.components == alone.components and first.body == second.body == alone.body
    # the counters are the run's own, not the warm backend's running totals
    assert first.provenance["llm_calls"] == second.provenance["llm_calls"] == alone.provenance["llm_calls"]


def test_another_model_closes_the_warm_one_first(toy, tmp_path):
    models = Models()
    worker = ModelWorker(models)
    a, b = tmp_path / "a.gguf", tmp_path / "b.gguf"
    a.write_bytes(b"a")
    b.write_bytes(b"b")
    try:
        worker(toy, Settings(use_cache=False, model=str(a)), no_progress)
        worker(toy, Settings(use_cache=False, model=str(b)), no_progress)
        worker(toy, Settings(use_cache=False, model=str(b)), no_progress)
    finally:
        worker.release()
    assert [m.name for m in models.made] == [f"scripted:{a}", f"scripted:{b}"]
    assert models.most_open == 1 and models.open == 0


def test_structure_only_and_result_cache_hits_load_nothing(toy, tmp_path, monkeypatch):
    monkeypatch.setenv("URDFKB_RESULT_CACHE", str(tmp_path))
    models = Models()
    worker = ModelWorker(models)
    assert worker(toy, Settings(structure_only=True), no_progress).components == ()
    assert models.made == []
    computed = worker(toy, Settings(), no_progress)
    worker.release()
    assert worker(toy, Settings(), no_progress).components == computed.components  # from the result cache
    assert worker.loads == 1


def test_runs_never_overlap_and_keep_their_order(toy):
    running: list[int] = []
    order: list[tuple] = []
    overlap: list[str] = []

    def slow(question):
        if running:
            overlap.append(question.key)
        running.append(1)
        time.sleep(0.001)
        running.pop()
        return perfect(question)

    models = Models(slow)
    worker = ModelWorker(models)
    threads = [threading.Thread(target=lambda i=i: order.append((i, worker(toy, Settings(use_cache=False), no_progress))))
               for i in range(3)]
    for t in threads:
        t.start()
        time.sleep(0.05)  # queued in this order
    for t in threads:
        t.join(60)
    worker.release()
    assert not overlap and len(order) == 3 and models.most_open == 1 and worker.loads == 1


def test_a_failing_run_reaches_its_job_and_the_worker_goes_on(toy):
    def broken(question):
        raise BackendError("model broke")

    worker = ModelWorker(Models(broken))
    with pytest.raises(BackendError, match="model broke"):
        worker(toy, Settings(use_cache=False), no_progress)
    worker._make = Models()
    worker.release()
    assert worker(toy, Settings(use_cache=False), no_progress).components
    worker.release()


def test_jobs_share_the_worker_and_shutdown_closes_the_model(store, toy):
    models = Models()
    worker = ModelWorker(models)
    jobs = JobManager(store, worker)
    first = jobs.submit(toy, "toy", Settings(use_cache=False))
    second = jobs.submit(toy, "toy2", Settings(use_cache=False))
    assert first.wait(60) and second.wait(60)
    assert (first.state, second.state) == ("succeeded", "succeeded"), (first.errors, second.errors)
    jobs.shutdown()
    assert worker.loads == 1 and models.open == 0
