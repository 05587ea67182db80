"""The data of the SPARQL benchmarks: renamed copies of a populated PR2, and each bundled query bound for one copy.

PR2 is populated by the store from shared/urdf/pr2.urdf and the hand-written whole-body abstraction of
tests/kb_fixtures.py (PR2_WHOLE: frames, specs, reach and body included); copy i is its robot graph with
the robot's namespace renamed to that of robot `pr2_<i>` (a graph of its own, as a populate would make).
"""
from __future__ import annotations

import io
import sqlite3
import tempfile
from pathlib import Path

import pyoxigraph as ox

from tests.kb_fixtures import PR2_WHOLE
from tests.shared_assets import SHARED
from urdfkb.kb_server.queries import load_queries
from urdfkb.kb_server.store import Store
from urdfkb.pipeline.reading.ingest import load_urdf
from urdfkb.pipeline.knowledge.namespaces import CORE_GRAPH, ROBOT, robot_iri

PARAMS = {"mounted_below": {"link": "base_link"}}  # what a bundled query needs beyond its defaults


def pr2_graphs() -> tuple[bytes, bytes]:
    """(the core ontology's graph, PR2's robot graph) as the server's index holds them, N-Triples."""
    with tempfile.TemporaryDirectory() as tmp:
        store = Store(Path(tmp) / "kb.sqlite3", workers=0)
        try:
            store.replace_robot("pr2", load_urdf(SHARED / "urdf" / "pr2.urdf"), PR2_WHOLE)
            return _dump(store, CORE_GRAPH), _dump(store, robot_iri("pr2"))
        finally:
            store.close()


def _dump(store: Store, graph: str) -> bytes:
    buf = io.BytesIO()
    store.index.master.dump(buf, format=ox.RdfFormat.N_TRIPLES, from_graph=ox.NamedNode(graph))
    return buf.getvalue()


def copy_name(i: int) -> str:
    return f"pr2_{i:03d}"


def renamed(pr2: bytes, i: int) -> tuple[str, bytes]:
    """(graph IRI, N-Triples) of copy `i` of PR2's robot graph."""
    name = copy_name(i)
    return robot_iri(name), pr2.replace(f"<{robot_iri('pr2')}".encode(), f"<{robot_iri(name)}".encode())


def store_file(path: Path, graphs: dict[str, bytes]) -> None:
    """A new urdfkb store file at `path` holding `graphs` as a SPARQL update inserting them leaves them (rows of
    table kb_graphs, which the server's index is built from at start), written at once: an update dumps every
    graph before and after, which 100 copies make minutes of work."""
    Store(path, workers=0).close()  # the core and the store's tables
    with sqlite3.connect(path) as db:
        db.executemany("INSERT INTO kb_graphs VALUES (?, ?)", graphs.items())
    db.close()


def insert_data(graph: str, ntriples: bytes) -> bytes:
    """The SPARQL update adding `ntriples` to `graph` (N-Triples lines are SPARQL triples)."""
    return b"INSERT DATA { GRAPH <" + graph.encode() + b"> {\n" + ntriples + b"} }"


def bound_queries(i: int, names: list[str] | None = None) -> dict[str, str]:
    """Every bundled query (or those in `names`) bound for copy `i`, by name."""
    queries = load_queries()
    return {name: q.bind(robot_iri(copy_name(i)) + ROBOT, PARAMS.get(name, {}))
            for name, q in queries.items() if names is None or name in names}
