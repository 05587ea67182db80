"""Bounded work per request (issue 39): a correction's links capped and its errors short, corrections and the
fork computed in time linear in the robot, what corrections make of a robot and its exports computed outside
the store lock and kept until a write of the robot; a dropped robot's corrections graph refuses writers and
the index shows after a restart what it showed before."""
from __future__ import annotations

import json
import random
import threading
from typing import Any, Callable, TypeVar

import pytest

from tests.kb_fixtures import client, copied, make_app
from urdfkb.kb_server import corrections as review
from urdfkb.kb_server import store as store_module
from urdfkb.kb_server.corrections import Correction, CorrectionError, corrections_iri
from urdfkb.kb_server.store import ReadOnlyGraph, Store
from urdfkb.pipeline.reading.ingest import load_urdf
from urdfkb.pipeline.reading.tree import Edge, KinematicTree, Origin, fork_of
from urdfkb.settings import MAX_LINKS

T = TypeVar("T")

TOKEN = "t0k"
PR2_GRAPH = "https://w3id.org/urdfkb/robot/pr2#"
ZERO = Origin((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))


def chain(n: int) -> KinematicTree:
    """A chain of `n` links l0..l{n-1} joined by revolute joints."""
    links = "".join(f'<link name="l{i}"/>' for i in range(n))
    joints = "".join(f'<joint name="j{i}" type="revolute"><parent link="l{i - 1}"/><child link="l{i}"/>'
                     f'<origin xyz="0 0 0.1"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/>'
                     "</joint>" for i in range(1, n))
    return load_urdf(f'<robot name="chain">{links}{joints}</robot>'.encode())


def lock_free(store: Store) -> bool:
    """True when another thread may take the store lock at once (this thread does not hold it)."""
    got: list[bool] = []

    def take() -> None:
        got.append(store.lock.acquire(timeout=1))
        if got[0]:
            store.lock.release()
    t = threading.Thread(target=take)
    t.start()
    t.join()
    return got == [True]


def test_the_fork_is_the_lowest_common_ancestor_on_random_trees():
    rng = random.Random(7)
    for _ in range(50):
        n = rng.randint(1, 60)
        tree = KinematicTree("t", tuple(f"l{i}" for i in range(n)),
                             tuple(Edge(f"j{i}", "fixed", f"l{rng.randrange(i)}", f"l{i}", ZERO) for i in range(1, n)))
        leaves = rng.sample(tree.links, rng.randint(1, min(n, 6)))
        common = [a for a in tree.chain_to_root(leaves[0]) if all(a in tree.chain_to_root(x) for x in leaves)]
        assert fork_of(tree, leaves) == common[0]


@pytest.mark.slow
def test_an_added_component_over_a_whole_chain_has_one_end(store):
    """The ends of an added component (its links above none of the others) come from one walk up the tree:
    over every link of a chain, only the tip gets the part the class requires."""
    store.replace_robot("chain", chain(20), None)
    links = [f"l{i}" for i in range(1, 20)]
    store.add_correction("chain", Correction.new({"action": "add", "class": "MonocularCamera", "links": links}, "ann"))
    (added,) = store.reviewed("chain").corrected.components
    assert added.root == "l0" and [s.link for s in added.subcomponents if s.cls != "Subpart"] == ["l19"]


def test_a_correction_names_at_most_as_many_links_as_a_robot_may_have():
    too_many = [f"made_up_{i}" for i in range(MAX_LINKS + 1)]
    with pytest.raises(CorrectionError, match=f"at most {MAX_LINKS:,} links") as e:
        Correction.new({"action": "reject", "links": too_many}, "ann")
    assert len(str(e.value)) < 200


def test_made_up_links_are_refused_naming_the_first_few(pr2_store):
    app, jobs = make_app(pr2_store, token=TOKEN)
    made_up = [f"no_such_link_{i:05d}" for i in range(MAX_LINKS)]
    body = json.dumps({"action": "add", "class": "Camera", "links": made_up}).encode()
    status, _, out = client(app)("POST", "/robots/pr2/corrections", body,
                                 {"Content-Type": "application/json", "Authorization": f"Bearer {TOKEN}"})
    jobs.shutdown()
    error = json.loads(out)["error"]
    assert status == 400 and len(out) < 1024
    assert error == f"link no_such_link_00000, no_such_link_00001, no_such_link_00002, no_such_link_00003, " \
                    f"no_such_link_00004 and {MAX_LINKS - 5:,} more are not in the URDF any more"


def spied(func: Callable[..., T], note: Callable[[], None]) -> Callable[..., T]:
    """`func`, calling `note()` before each call."""
    def call(*args: Any) -> T:
        note()
        return func(*args)
    return call


@pytest.mark.slow  # over a second of its own (make test-fast leaves it out)
def test_a_correction_is_checked_outside_the_lock_and_what_it_makes_is_kept(pr2_store, monkeypatch):
    seen: list[bool] = []
    check = review.check
    monkeypatch.setattr(review, "check", spied(check, lambda: seen.append(lock_free(pr2_store))))
    pr2_store.add_correction("pr2", Correction.new({"action": "confirm", "links": ["base_laser_link"]}, "ann"))
    assert seen == [True]
    calls: list[int] = []
    monkeypatch.setattr(review, "apply", spied(review.apply, lambda: calls.append(1)))
    kept = pr2_store.reviewed("pr2")  # the write left what it made
    assert [c.action for c, _ in kept.report.applied] == ["confirm"] and calls == []
    pr2_store.replace_robot("other", chain(3), None)  # another robot's write keeps it
    calls.clear()
    assert pr2_store.reviewed("pr2") is kept and calls == []
    pr2_store.update(f"INSERT DATA {{ GRAPH <{PR2_GRAPH}> {{ <urn:a> <urn:b> <urn:c> }} }}")  # a write of pr2's graph
    again = pr2_store.reviewed("pr2")
    assert again is not kept and again.report.to_dict() == kept.report.to_dict() and len(calls) == 1
    assert pr2_store.reviewed("pr2") is again and len(calls) == 1


def test_pages_and_corrections_routes_never_compute_again(pr2_store, monkeypatch):
    app, jobs = make_app(pr2_store)
    api = client(app)
    assert api("GET", "/robots/pr2/corrections")[0] == 200
    calls: list[int] = []
    monkeypatch.setattr(review, "apply", spied(review.apply, lambda: calls.append(1)))
    for _ in range(2):
        assert api("GET", "/robots/pr2/corrections")[0] == 200
        assert api("GET", "/robots/pr2", headers={"Accept": "text/html"})[0] == 200
    jobs.shutdown()
    assert calls == []


@pytest.mark.slow
def test_exports_are_made_outside_the_lock_once_per_write(pr2_store, monkeypatch):
    made: list[bool] = []
    export_graph = store_module.export_graph
    monkeypatch.setattr(store_module, "export_graph", spied(export_graph, lambda: made.append(lock_free(pr2_store))))
    first = pr2_store.export("pr2", "ttl")
    assert made == [True]
    with pr2_store.lock:  # a write under way elsewhere does not hold up an export already made
        held = threading.Thread(target=lambda: made.append(pr2_store.export("pr2", "ttl") == first))
        held.start()
        held.join(5)
    assert made == [True, True]
    pr2_store.add_correction("pr2", Correction.new({"action": "confirm", "links": ["base_laser_link"]}, "ann"))
    after = pr2_store.export("pr2", "ttl")
    assert len(made) == 3 and b"base_laser_link: confirmed" in after and b"confirmed" not in first
    assert pr2_store.export("ghost", "ttl") is None


def test_a_dropped_robots_corrections_graph_refuses_writers_and_survives_a_restart(pr2_kb, tmp_path):
    path = copied(pr2_kb, tmp_path)
    store = Store(path, workers=0)
    store.add_correction("pr2", Correction.new({"action": "confirm", "links": ["base_laser_link"]}, "ann"))
    store.update(f"DROP GRAPH <{PR2_GRAPH}>")
    assert store.robot("pr2") is None
    for graph in (corrections_iri("pr2"), corrections_iri("never_stored")):
        with pytest.raises(ReadOnlyGraph, match="read-only"):
            store.update(f"INSERT DATA {{ GRAPH <{graph}> {{ <urn:a> <urn:b> <urn:c> }} }}")
    every = "SELECT ?g (COUNT(*) AS ?n) WHERE { GRAPH ?g { ?s ?p ?o } } GROUP BY ?g ORDER BY ?g"
    before = json.loads(store.query(every).body)["results"]["bindings"]
    assert corrections_iri("pr2") in {b["g"]["value"] for b in before}
    store.close()
    store = Store(path, workers=0)
    try:
        assert json.loads(store.query(every).body)["results"]["bindings"] == before
    finally:
        store.close()


@pytest.mark.slow
def test_an_update_row_for_a_corrections_graph_is_dropped_at_open(pr2_kb, tmp_path):
    """A store where an earlier version let an update write a dropped robot's corrections graph: the row, which
    the index showed only after a restart, goes, and the world's corrections are what SPARQL shows."""
    path = copied(pr2_kb, tmp_path)
    store = Store(path, workers=0)
    store.add_correction("pr2", Correction.new({"action": "confirm", "links": ["base_laser_link"]}, "ann"))
    with store.lock:
        store.db.execute("INSERT INTO kb_graphs VALUES (?, ?)", (corrections_iri("pr2"), b"<urn:a> <urn:b> <urn:c> .\n"))
        store.world.save()
    store.close()
    store = Store(path, workers=0)
    try:
        assert json.loads(store.query("ASK { <urn:a> ?p ?o }").body)["boolean"] is False
        assert [c.action for c in store.corrections("pr2")] == ["confirm"]
        assert store.db.execute("SELECT COUNT(*) FROM kb_graphs").fetchone() == (0,)
    finally:
        store.close()
