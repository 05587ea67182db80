"""The result cache (kb_server/result_cache.py): a query asked again is answered with the same bytes without being
evaluated, until a write of any kind; a query submitted after a write returned never gets an answer from before
it; volatile functions, refusals and errors are never kept; the bound is on bytes; no-cache and 0 turn it off."""
from __future__ import annotations

import threading
from dataclasses import replace

import pytest

from tests.kb_fixtures import PR2, client, copied, make_app
from urdfkb.kb_server import index as index_mod
from urdfkb.kb_server.corrections import Correction
from urdfkb.kb_server.result_cache import ResultCache, cache_key, no_cache
from urdfkb.kb_server.serve import make_server
from urdfkb.kb_server.sparql import QueryError, Result
from urdfkb.kb_server.store import Store
from urdfkb.pipeline.abstraction.components import Abstraction
from urdfkb.pipeline.errors import UrdfkbError

CORE = "https://w3id.org/urdfkb/core#"
COMPONENTS = f"SELECT (COUNT(?c) AS ?n) WHERE {{ ?r <{CORE}hasComponent> ?c }}"
PROSILICA = (f"SELECT ?class WHERE {{ <https://w3id.org/urdfkb/robot/pr2#comp_prosilica> a ?class "
             f"FILTER(STRSTARTS(STR(?class), '{CORE}')) }}")
VALUE = "SELECT ?o WHERE { GRAPH <urn:x:g> { <urn:x:s> <urn:x:p> ?o } }"


def set_value(i: int) -> str:
    return (f"DELETE WHERE {{ GRAPH <urn:x:g> {{ <urn:x:s> <urn:x:p> ?o }} }}; "
            f"INSERT DATA {{ GRAPH <urn:x:g> {{ <urn:x:s> <urn:x:p> {i} }} }}")


@pytest.fixture
def evaluations(monkeypatch):
    """The queries evaluated in this process (by stores without workers) from now on."""
    seen: list[str] = []
    real = index_mod.run_query

    def run_query(store, text, *args, **kw):
        seen.append(text)
        return real(store, text, *args, **kw)
    monkeypatch.setattr(index_mod, "run_query", run_query)
    return seen


def count(store: Store) -> int:
    return int(store.query(COMPONENTS).as_dicts()[0]["n"])


def test_a_query_asked_again_gets_the_same_bytes_without_being_evaluated(pr2_store, evaluations):
    first = pr2_store.query(COMPONENTS, accept="application/sparql-results+xml")
    again = pr2_store.query(COMPONENTS, accept="application/sparql-results+xml")
    assert (again.kind, again.media_type, again.body) == (first.kind, first.media_type, first.body)
    assert evaluations == [COMPONENTS]
    as_json = pr2_store.query(COMPONENTS)  # another Accept, another answer
    assert as_json.body != first.body and evaluations == [COMPONENTS] * 2
    pr2_store.query(COMPONENTS, default_graphs=["https://w3id.org/urdfkb/robot/pr2#"])  # another dataset
    assert len(evaluations) == 3


@pytest.mark.slow  # over a second of its own (make test-fast leaves it out)
def test_every_kind_of_write_is_seen_by_the_next_query(pr2_store, pr2_tree):
    whole = count(pr2_store)
    pr2_store.update(f"INSERT DATA {{ GRAPH <urn:x:g> {{ <urn:x:r> <{CORE}hasComponent> <urn:x:c> }} }}")
    assert count(pr2_store) == whole + 1
    pr2_store.update("DROP GRAPH <urn:x:g>")
    assert count(pr2_store) == whole
    pr2_store.replace_robot("pr2", pr2_tree, Abstraction(PR2.components[-1:]))  # a populate: one sensor left
    assert 0 < count(pr2_store) < whole
    pr2_store.replace_robot("pr2", pr2_tree, PR2)
    assert pr2_store.query(PROSILICA).as_dicts() == [{"class": f"{CORE}MonocularCamera"}]
    pr2_store.add_correction("pr2", Correction.new({"action": "reclassify", "links": ["head_mount_prosilica_optical_frame"],
                                                    "class": "StereoCamera"}, "ann"))
    assert pr2_store.query(PROSILICA).as_dicts() == [{"class": f"{CORE}StereoCamera"}]
    pr2_store.delete_robot("pr2")
    assert count(pr2_store) == 0 and pr2_store.query(PROSILICA).as_dicts() == []


def test_an_answer_a_write_overtook_is_not_kept(store, monkeypatch):
    """Evaluated before a write and answered after it began: given to its caller, never to a later one."""
    store.update(set_value(1))
    real = index_mod.run_query

    def evaluate_then_write(*args, **kw):
        result = real(*args, **kw)
        monkeypatch.setattr(index_mod, "run_query", real)
        store.update(set_value(2))
        return result
    monkeypatch.setattr(index_mod, "run_query", evaluate_then_write)
    assert store.query(VALUE).as_dicts() == [{"o": "1"}]
    assert store.query(VALUE).as_dicts() == [{"o": "2"}]


def test_an_update_that_writes_nothing_leaves_no_answer_it_let_be_read(store, monkeypatch):
    """Without workers an update is evaluated on the master and undone there: an answer read meanwhile is not kept."""
    store.update(set_value(1))
    real = index_mod.run_update

    def update_read_meanwhile(target, text):
        changes = real(target, text)
        assert store.index.master is target and store.query(VALUE).as_dicts() == [{"o": "7"}]
        return changes
    monkeypatch.setattr(index_mod, "run_update", update_read_meanwhile)
    with pytest.raises(UrdfkbError):  # the core is read-only: the transaction writes nothing
        store.update(set_value(7) + f"; INSERT DATA {{ GRAPH <{CORE}> {{ <urn:x:a> <urn:x:b> <urn:x:c> }} }}")
    monkeypatch.setattr(index_mod, "run_update", real)
    assert store.query(VALUE).as_dicts() == [{"o": "1"}]


@pytest.mark.slow  # over a second of its own (make test-fast leaves it out)
def test_a_query_after_a_write_returned_sees_it_whatever_readers_keep_meanwhile(tmp_path):
    """Readers on the workers keep answering (and keeping) the value while a writer changes it: after each write
    returns, the writer's own query sees that write."""
    store = Store(tmp_path / "kb.sqlite3", workers=2)
    stop, seen = threading.Event(), []

    def read() -> None:
        while not stop.is_set():
            seen.append(store.query(VALUE).body)
    readers = [threading.Thread(target=read) for _ in range(2)]
    try:
        store.update(set_value(0))
        for r in readers:
            r.start()
        for i in range(1, 25):
            store.update(set_value(i))
            assert store.query(VALUE).as_dicts() == [{"o": str(i)}]
    finally:
        stop.set()
        for r in readers:
            r.join(10)
        store.close()
    assert len(seen) > 24  # the readers did read meanwhile


@pytest.mark.parametrize("function", ["RAND()", "NOW()", "UUID()", "STRUUID()", "BNODE()", 'bnode("x")'])
def test_a_query_calling_a_volatile_function_is_evaluated_each_time(store, evaluations, function):
    text = f"SELECT ({function} AS ?v) WHERE {{}}"
    assert cache_key(text, None, None, None) is None
    store.query(text)
    store.query(text)
    assert evaluations == [text, text]


def test_two_rands_differ(store):
    text = "SELECT (RAND() AS ?r) WHERE {}"
    assert store.query(text).body != store.query(text).body


def test_errors_and_refused_queries_are_never_kept(store, evaluations):
    refused = "SELECT * WHERE { SERVICE <http://example.org/sparql> { ?s ?p ?o } }"
    assert cache_key(refused, None, None, None) is None
    missing = "SELECT * FROM <urn:x:g> WHERE { ?s ?p ?o }"  # no such graph yet
    for text in (refused, refused, "SELEC", "SELEC", missing):
        with pytest.raises(QueryError):
            store.query(text)
    assert evaluations == [refused, refused, "SELEC", "SELEC", missing]
    store.update(set_value(3))
    assert store.query(missing).as_dicts() == [{"s": "urn:x:s", "p": "urn:x:p", "o": "3"}]


def test_no_cache_evaluates_again_and_refreshes_what_is_kept(store, evaluations):
    store.update(set_value(1))
    first = store.query(VALUE)
    assert store.query(VALUE, fresh=True).body == first.body and store.query(VALUE).body == first.body
    assert evaluations == [VALUE, VALUE]
    assert no_cache("no-cache") and no_cache("max-age=0, No-Cache") and no_cache('no-cache="Age"')
    assert not no_cache(None) and not no_cache("no-store") and not no_cache("max-age=0")


def test_the_route_evaluates_a_query_sent_with_no_cache(pr2_store, evaluations):
    app, jobs = make_app(pr2_store)
    call = client(app)
    try:
        answers = [call("GET", "/sparql?query=ASK%7B%7D", None, headers) for headers in
                   ({}, {}, {"Cache-Control": "no-cache"}, {"Cache-Control": "max-age=5"})]
    finally:
        jobs.shutdown()
    assert len(set(answers)) == 1 and answers[0][0] == 200
    assert evaluations == ["ASK{}", "ASK{}"]


def test_a_cache_of_0_keeps_nothing(pr2_kb, tmp_path, evaluations):
    s = Store(copied(pr2_kb, tmp_path), workers=0, result_cache=0)
    try:
        assert s.query(COMPONENTS).body == s.query(COMPONENTS).body
    finally:
        s.close()
    assert evaluations == [COMPONENTS] * 2
    with pytest.raises(UrdfkbError, match="--result-cache"):
        make_server(tmp_path / "other.sqlite3", port=0, result_cache=-1)


def _answer(size: int) -> Result:
    return Result("bindings", "application/sparql-results+json", b"x" * size)


def test_the_bound_is_on_bytes_least_recently_used_out_first():
    cache = ResultCache(1600)  # answers of at most 100 bytes (a sixteenth), keys included
    keys = [k for i in range(18) if (k := cache_key(f"ASK {{ <urn:x:{i:02}> ?p ?o }}", None, None, None))]
    size = 100 - len(keys[0][0])
    for k in keys[:16]:
        cache.put(k, cache.generation, _answer(size))
    assert len(cache) == 16 and cache.bytes == 1600
    cache.put(keys[16], cache.generation, _answer(size + 1))  # over a sixteenth: not kept
    assert cache.get(keys[16]) is None and cache.bytes == 1600
    assert cache.get(keys[0]) is not None  # now the most recently used
    cache.put(keys[17], cache.generation, _answer(size))
    assert [cache.get(k) is not None for k in keys[:3]] == [True, False, True] and cache.get(keys[17]) is not None
    assert len(cache) == 16 and cache.bytes == 1600


def test_an_answer_of_an_older_generation_is_not_kept():
    cache = ResultCache(1 << 20)
    k = cache_key("ASK {}", None, None, None)
    assert k is not None
    taken = cache.generation
    cache.put(k, taken, _answer(10))
    kept = cache.get(k)
    assert kept is not None and kept.body == b"x" * 10
    cache.invalidate()
    assert cache.get(k) is None and len(cache) == 0 and cache.bytes == 0
    cache.put(k, taken, _answer(10))  # evaluated before the write: dropped
    assert cache.get(k) is None
    cache.put(k, cache.generation, replace(_answer(10), body=b"y"))
    assert cache.get(k) == Result("bindings", "application/sparql-results+json", b"y")
