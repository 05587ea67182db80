"""The persistent store: restart, atomic replace, failures leave it as it was, exports, timeouts."""
import multiprocessing
import threading
import time

import pytest
import rdflib

import urdfkb.kb_server.index as index_mod
import urdfkb.kb_server.store as store_mod
from tests.kb_fixtures import PR2
from urdfkb.kb_server.results import ResultLimits
from urdfkb.kb_server.sparql import QueryTimeout
from urdfkb.kb_server.store import Store
from urdfkb.pipeline.abstraction.components import Abstraction
from urdfkb.pipeline.errors import OntologyError, UrdfkbError
from urdfkb.pipeline.reading.ingest import load_urdf

COUNT_COMPONENTS = """PREFIX core: <https://w3id.org/urdfkb/core#>
SELECT (COUNT(?c) AS ?n) WHERE { <https://w3id.org/urdfkb/robot/pr2#robot> core:hasComponent ?c }"""


@pytest.fixture(scope="module")
def trees(shared):
    return {n: load_urdf(shared / "urdf" / f"{n}.urdf") for n in ("pr2", "panda")}


def components(store) -> int:
    return int(store.query(COUNT_COMPONENTS).as_dicts()[0]["n"])


def test_restart_serves_everything_stored(tmp_path, trees):
    path = tmp_path / "kb.sqlite3"
    s = Store(path, workers=0)
    s.replace_robot("pr2", trees["pr2"], PR2)
    s.replace_robot("panda", trees["panda"], None)
    s.close()
    s = Store(path, workers=0)
    assert [e.name for e in s.robots()] == ["panda", "pr2"]
    assert s.require("pr2").robot_iri == "https://w3id.org/urdfkb/robot/pr2#robot"
    assert components(s) == len(PR2.components)
    s.close()


def test_a_store_with_robots_written_without_their_urdf_tree_is_refused_naming_them(tmp_path, trees):
    """Development versions before reviewers' corrections kept no tree (table kb_sources): nothing can be laid
    over such a robot, and without its URDF it cannot be migrated."""
    path = tmp_path / "kb.sqlite3"
    s = Store(path, workers=0)
    for name in ("pr2", "panda"):
        s.replace_robot(name, trees[name], None)
    with s.lock:
        s.db.execute("DELETE FROM kb_sources WHERE name='panda'")
        s.world.save()
    s.close()
    with pytest.raises(UrdfkbError, match=r"without their URDF tree: panda\. Populate them again from their URDF"):
        Store(path, workers=0)


@pytest.mark.slow  # over a second of its own (make test-fast leaves it out)
def test_replace_is_whole_and_failures_leave_the_old_robot(store, trees, monkeypatch):
    store.replace_robot("pr2", trees["pr2"], PR2)
    store.replace_robot("pr2", trees["pr2"], Abstraction(PR2.components[:2]))
    assert components(store) == 2
    bad = Abstraction((PR2.components[0].__class__(**{**PR2.components[0].__dict__, "cls": "Toaster"}),))
    with pytest.raises(OntologyError):
        store.replace_robot("pr2", trees["pr2"], bad)
    assert components(store) == 2

    real = store_mod.build_robot

    def build_then_fail(*args, **kw):
        real(*args, **kw)  # old robot destroyed, new one half-committed in the transaction
        raise RuntimeError("disk on fire")

    monkeypatch.setattr(store_mod, "build_robot", build_then_fail)
    with pytest.raises(RuntimeError):
        store.replace_robot("pr2", trees["pr2"], PR2)
    assert components(store) == 2
    assert store.query(COUNT_COMPONENTS.replace("hasComponent ?c", "hasLink ?c")).as_dicts()[0]["n"] == str(len(trees["pr2"].links))


@pytest.mark.slow  # over a second of its own (make test-fast leaves it out)
def test_readers_never_see_a_mix(tmp_path, trees):
    s = Store(tmp_path / "kb.sqlite3", workers=2)  # readers on the workers, which apply a write whole
    small, full = Abstraction(PR2.components[:1]), PR2
    s.replace_robot("pr2", trees["pr2"], small)
    seen, stop, end = set(), threading.Event(), time.monotonic() + 60

    def read():
        while not stop.is_set() and time.monotonic() < end:
            seen.add(components(s))

    reader = threading.Thread(target=read)
    reader.start()
    for i in range(6):
        s.replace_robot("pr2", trees["pr2"], full if i % 2 else small)
    stop.set()
    reader.join(10)
    assert seen <= {1, len(full.components)}
    s.close()


@pytest.mark.slow  # over a second of its own (make test-fast leaves it out)
def test_delete_and_exports(store, trees):
    store.replace_robot("pr2", trees["pr2"], PR2)
    for ext, fmt in (("owl", "xml"), ("ttl", "turtle"), ("nt", "nt")):
        g = rdflib.Graph().parse(data=store.export("pr2", ext), format=fmt)
        core = rdflib.Namespace("https://w3id.org/urdfkb/core#")
        assert (rdflib.URIRef("https://w3id.org/urdfkb/robot/pr2#comp_kinect"), rdflib.RDF.type, core.RGBDCamera) in g
        assert (core.RGBDCamera, rdflib.RDFS.subClassOf, core.Camera) in g  # self-contained: core merged in
    assert store.delete_robot("pr2").name == "pr2"
    assert store.delete_robot("pr2") is None and store.export("pr2", "ttl") is None
    assert components(store) == 0


@pytest.mark.slow
def test_timeout_stops_the_query_and_the_store_keeps_serving(tmp_path, trees):
    s = Store(tmp_path / "kb.sqlite3", workers=2)  # a deadline is the workers' to enforce
    s.replace_robot("pr2", trees["pr2"], PR2)
    cross = "SELECT (COUNT(*) AS ?n) WHERE { ?a ?b ?c . ?d ?e ?f . ?g ?h ?i }"
    for q in (cross, cross.replace("}", "MINUS { ?a a <urn:x> } }")):
        with pytest.raises(QueryTimeout):
            s.query(q, timeout=0.5)
    assert components(s) == len(PR2.components)  # the worker past its deadline was replaced
    s.close()


def test_a_query_worker_whose_server_died_before_it_started_ends():
    """Killed while starting its workers, a server leaves children that start under another parent
    (seen after the restart test): such a worker returns at once instead of waiting on its queue."""
    ctx = multiprocessing.get_context("spawn")
    requests, replies = ctx.Pipe(duplex=False)
    gone = ctx.Process(target=time.sleep, args=(0,))  # a pid that is nobody's parent once it has ended
    gone.start()
    gone.join(60)
    inbox = ctx.Queue()  # held here until the worker has read it
    worker = ctx.Process(target=index_mod._serve, args=(inbox, requests, replies, gone.pid, ResultLimits(memory=2**30)),
                         daemon=True)
    worker.start()
    worker.join(60)
    assert worker.exitcode == 0


@pytest.mark.slow  # over a second of its own (make test-fast leaves it out)
def test_an_update_applies_to_the_state_it_read(store, trees, monkeypatch):
    """A populate that lands between an update's evaluation (which holds no lock) and its transaction
    makes the update evaluate again: what it stores is computed from the robot as it is now."""
    store.replace_robot("pr2", trees["pr2"], PR2)
    real, evaluated = store.index.update, []

    def update_then_populate(text, timeout):
        changes = real(text, timeout)
        evaluated.append(text)
        if len(evaluated) == 1:
            store.replace_robot("pr2", trees["pr2"], Abstraction(PR2.components[:2]))
        return changes

    monkeypatch.setattr(store.index, "update", update_then_populate)
    store.update("""PREFIX core: <https://w3id.org/urdfkb/core#>
INSERT { GRAPH <urn:x:counts> { <urn:x:pr2> <urn:x:components> ?n } }
WHERE { SELECT (COUNT(?c) AS ?n) WHERE { GRAPH ?g { <https://w3id.org/urdfkb/robot/pr2#robot> core:hasComponent ?c } } }""")
    assert len(evaluated) == 2
    assert store.query("SELECT ?n WHERE { GRAPH <urn:x:counts> { ?r ?p ?n } }").as_dicts() == [{"n": "2"}]


@pytest.mark.slow
def test_an_update_waiting_for_a_worker_holds_up_no_other_store_operation(tmp_path, trees):
    s = Store(tmp_path / "kb.sqlite3", workers=1)
    s.replace_robot("pr2", trees["pr2"], PR2)
    s.replace_robot("panda", trees["panda"], None)
    cross = "SELECT (COUNT(*) AS ?n) WHERE { ?a ?b ?c . ?d ?e ?f . ?g ?h ?i }"

    def busy():
        with pytest.raises(QueryTimeout):
            s.query(cross, timeout=3)

    query = threading.Thread(target=busy)
    query.start()
    time.sleep(0.5)  # the query holds the only worker until its deadline
    update = threading.Thread(target=s.update, args=("INSERT DATA { <urn:x:a> <urn:x:b> <urn:x:c> }", 30))
    update.start()
    time.sleep(0.5)  # the update waits for the worker
    started = time.monotonic()
    assert s.lock.acquire(timeout=1)
    s.lock.release()
    deleted = s.delete_robot("panda")  # a write goes through meanwhile
    assert deleted is not None and deleted.name == "panda"
    assert time.monotonic() - started < 2 and query.is_alive() and update.is_alive()
    query.join(30)
    update.join(30)
    assert s.query("ASK { <urn:x:a> <urn:x:b> <urn:x:c> }").document["boolean"] is True
    assert [e.name for e in s.robots()] == ["pr2"]
    s.close()


def test_the_robot_list_never_waits_for_a_write(store, trees):
    store.replace_robot("pr2", trees["pr2"], PR2)
    seen = []
    with store.lock:  # as a populate's transaction holds it
        reader = threading.Thread(target=lambda: seen.extend([[e.name for e in store.robots()], store.robot("pr2").name]))
        reader.start()
        reader.join(5)
    assert seen == [["pr2"], "pr2"]
