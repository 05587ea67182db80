"""Settings, the result cache, and the runner's contract with its callers."""
from __future__ import annotations

import time
from pathlib import Path

import pytest

from urdfkb.pipeline import cache
from urdfkb.pipeline.errors import BackendError
from urdfkb.pipeline.ingest import load_urdf
from urdfkb.pipeline.llm.scripted import ScriptedBackend
from urdfkb.pipeline.runner import Settings, run, tree_digest
from test_pipeline import perfect

TOY = Path(__file__).parent / "data" / "toy_robot.urdf"


@pytest.fixture(autouse=True)
def private_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("URDFKB_CACHE", str(tmp_path / "cache"))


def test_settings_from_user_input_are_typed_and_checked():
    s = Settings.from_mapping({"vote": "sample", "votes": "7", "use_cache": "false"})
    assert (s.vote, s.votes, s.use_cache) == ("sample", 7, False)
    for bad, message in [({"colour": "red"}, "unknown setting"), ({"votes": "many"}, "integer"),
                         ({"vote": "shout"}, "exact"), ({"votes": 0}, "between"),
                         ({"structure_only": "maybe"}, "true or false"),
                         ({"model": "a.gguf", "llm_url": "http://127.0.0.1:1"}, "either")]:
        with pytest.raises(ValueError, match=message):
            Settings.from_mapping(bad)


def test_structure_only_asks_nothing():
    backend = ScriptedBackend(perfect)
    result = run(load_urdf(TOY), Settings(structure_only=True), backend=backend)
    assert result.components == () and backend.stats.calls == 0


def test_an_identical_second_run_comes_from_the_cache():
    tree = load_urdf(TOY)
    first_backend = ScriptedBackend(perfect)
    first = run(tree, Settings(), backend=first_backend)
    assert first_backend.stats.calls > 0

    def must_not_be_called(q):
        raise AssertionError("the cache should have answered")
    started = time.monotonic()
    second = run(load_urdf(TOY), Settings(), backend=ScriptedBackend(must_not_be_called))
    assert second == first and time.monotonic() - started < 2


def test_other_settings_or_robots_miss_the_cache():
    tree = load_urdf(TOY)
    run(tree, Settings(), backend=ScriptedBackend(perfect))
    calls = ScriptedBackend(perfect)
    run(tree, Settings(vote="sample"), backend=calls)
    assert calls.stats.calls > 0
    other = load_urdf(TOY.read_bytes().replace(b"claw_tcp", b"claw_tool_point"))
    assert tree_digest(other) != tree_digest(tree)


def test_a_failing_backend_raises_and_caches_nothing(tmp_path):
    def broken(q):
        raise RuntimeError("out of memory")
    with pytest.raises(BackendError, match="out of memory"):
        run(load_urdf(TOY), Settings(), backend=ScriptedBackend(broken))
    assert not list((tmp_path / "cache").glob("**/*.json"))


def test_a_corrupt_cache_entry_is_ignored(tmp_path):
    tree = load_urdf(TOY)
    first = run(tree, Settings(), backend=ScriptedBackend(perfect))
    (entry,) = (tmp_path / "cache" / "results").glob("*.json")
    entry.write_text("{not json")
    again = run(tree, Settings(), backend=ScriptedBackend(perfect))
    assert again.components == first.components  # recomputed (its wall time may differ)
    assert cache.load(entry.stem) == again  # rewritten whole


def test_a_change_to_the_pipeline_code_misses_the_cache(monkeypatch):
    tree = load_urdf(TOY)
    run(tree, Settings(), backend=ScriptedBackend(perfect))
    monkeypatch.setattr(cache, "code_version", lambda: "an upgraded pipeline")
    again = ScriptedBackend(perfect)
    run(tree, Settings(), backend=again)
    assert again.stats.calls > 0


def test_a_single_link_robot_is_a_clear_error_not_a_crash():
    from urdfkb.pipeline.errors import URDFError
    tree = load_urdf(b'<robot name="lonely"><link name="only"/></robot>')
    with pytest.raises(URDFError, match="single link, 'only'"):
        run(tree, Settings(use_cache=False), backend=ScriptedBackend(lambda q: q.options[0]))
    assert run(tree, Settings(structure_only=True)).components == ()
