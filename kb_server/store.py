"""The persistent knowledge base: one owlready2 SQLite quadstore (the store of record, reached through
pipeline.knowledge.rdf) and its SPARQL index.

The quadstore holds the core ontology, one ontology per robot (its named graph: graph IRI =
ontology IRI), and, in table kb_graphs, the exact N-Triples of every other graph SPARQL Update
wrote (the default graph under ""). owlready2 is not thread-safe, so every access to the world
goes through `Store.lock`. Writes happen inside that lock in one SQLite transaction committed by
`world.save()`; a failure rolls back and reopens the world, and a crash leaves the last commit. A write
the disk refuses (full: DiskFull, 507; read-only or failing: StorageFault, 503) names the disk.

SPARQL is answered by the Oxigraph index (kb_server/index.py), rebuilt from the quadstore when the
store opens. Every write names the graphs it touched; after its transaction (committed or rolled
back) `_sync_graphs` copies those graphs from the quadstore into the index, so the index always
shows what is stored and SPARQL readers (who never take the lock) see the old graph or the new one.
The robot list (`robots`, `robot`) is a snapshot of table kb_robots taken after each write, read
without the lock too. What a robot's corrections make of it (`reviewed`) and its exports are computed
outside the lock, from what a short hold of it reads, and kept until a write touches the robot's graphs,
so a page, a GET of its corrections or an export never waits for a write's whole transaction and
never computes again what no write changed. Which lock comes before which: docs/concurrency.md.
"""
from __future__ import annotations

import io
import json
import logging
import re
import sqlite3
import threading
import time
from collections.abc import Iterable
from contextlib import contextmanager
from dataclasses import dataclass, field, replace
from datetime import datetime, timezone
from pathlib import Path

import rdflib
from platformdirs import user_data_dir
from rdflib.namespace import PROV

from urdfkb.kb_server import corrections as review
from urdfkb.kb_server.errors import DiskFull, StorageFault
from urdfkb.kb_server.index import Done, Index
from urdfkb.kb_server.results import ResultLimits
from urdfkb.kb_server.sparql import QueryTimeout, Result, scan
from urdfkb.pipeline.knowledge import rdf
from urdfkb.pipeline.abstraction.components import Abstraction
from urdfkb.pipeline.errors import ShapeError, UrdfkbError
from urdfkb.pipeline.knowledge.export import export_graph, robot_graph, robot_graph_of
from urdfkb.pipeline.knowledge.formats import BY_EXTENSION
from urdfkb.pipeline.knowledge.namespaces import CORE_GRAPH, CORE_IRI, ROBOT_BASE
from urdfkb.pipeline.knowledge.ontology import load_core
from urdfkb.pipeline.knowledge.population import build_robot
from urdfkb.pipeline.knowledge.shacl import violations
from urdfkb.pipeline.reading.tree import KinematicTree
from urdfkb.settings import QUERY_TIMEOUT, QUERY_WORKERS, RESULT_CACHE

log = logging.getLogger(__name__)

# kb_sources: the model's own answer per robot (tree and abstraction as JSON), so reviewers'
# corrections can be laid over it again whenever they change; the robot graph is model + corrections.
_SCHEMA = ("""CREATE TABLE IF NOT EXISTS kb_robots (
    name TEXT PRIMARY KEY, ontology_iri TEXT NOT NULL, robot_iri TEXT NOT NULL, updated TEXT NOT NULL)""",
           "CREATE TABLE IF NOT EXISTS kb_graphs (graph TEXT PRIMARY KEY, ntriples BLOB NOT NULL)",
           "CREATE TABLE IF NOT EXISTS kb_sources (name TEXT PRIMARY KEY, tree TEXT NOT NULL, abstraction TEXT NOT NULL)")


class ReadOnlyGraph(UrdfkbError, PermissionError):
    """An update would change the core ontology, which is read-only to SPARQL Update."""

    status = 403


ROBOT_NAME = re.compile(r"[A-Za-z0-9_-]{1,64}")  # the whole name: `$` would also match before a final "\n"
# A robot's graph or its corrections graph (namespaces.robot_iri, corrections_iri; a stored name needs no escape).
_ROBOT_GRAPH = re.compile(re.escape(ROBOT_BASE) + r"([A-Za-z0-9_-]{1,64})(/corrections)?#")
KEPT_REVIEWS = 16  # robots whose `reviewed` is kept (the most recently computed)
KEPT_EXPORT_BYTES = 256 << 20  # bytes of exports kept (the most recently made): a 5,000-link robot's .owl is 9.6 MB


class RobotNameError(UrdfkbError, ValueError):
    """A robot name the store cannot key on (it is also a URL path segment)."""

    status = 400


class UnknownRobot(UrdfkbError, LookupError):
    """No robot of that name in the store."""

    status = 404

    def __init__(self, name: str):
        super().__init__(f"no robot {name!r} in the store")


def check_robot_name(name: str) -> str:
    """`name` if it is 1-64 of A-Z a-z 0-9 _ - ; RobotNameError otherwise."""
    if not ROBOT_NAME.fullmatch(name or ""):
        raise RobotNameError(f"robot name {name!r} must be 1-64 of A-Z a-z 0-9 _ - (give another name)")
    return name


def storage_fault(err: sqlite3.OperationalError, path: Path) -> StorageFault | None:
    """The named fault for SQLite's refusal `err` to write the store at `path` (disk full, read-only, I/O
    error), naming the disk as the store file's directory; None for any other error."""
    code, where = (err.sqlite_errorcode or 0) & 0xFF, path.resolve().parent
    if code == sqlite3.SQLITE_FULL:
        return DiskFull(f"the disk holding the store ({where}) is full, so nothing was written: free space there and retry")
    if code == sqlite3.SQLITE_READONLY:
        return StorageFault(f"the store {path.name} in {where} is read-only (a read-only disk or file: {err}), "
                            "so nothing was written")
    if code == sqlite3.SQLITE_IOERR:
        return StorageFault(f"the disk holding the store ({where}) failed a write ({err}), so nothing was written")
    return None


def default_store_path() -> Path:
    """platformdirs user_data_dir("urdfkb")/kb.sqlite3."""
    return Path(user_data_dir("urdfkb")) / "kb.sqlite3"


@dataclass(frozen=True)
class RobotEntry:
    """A stored robot: its name, ontology IRI (also its named-graph IRI), Robot individual, update time."""

    name: str
    ontology_iri: str
    robot_iri: str
    updated: str

    def to_dict(self) -> dict:
        return {"name": self.name, "ontology": self.ontology_iri, "robot": self.robot_iri, "updated": self.updated}


@dataclass(frozen=True)
class Reviewed:
    """A robot's stored source (tree, the model's abstraction) and corrections, what laying the corrections
    over the model makes of it (`corrected`, `report`), and the robot's write count it was read at."""

    tree: KinematicTree
    model: Abstraction
    corrections: tuple[review.AnyCorrection, ...]
    corrected: Abstraction
    report: review.Report
    version: int

    @classmethod
    def of(cls, tree: KinematicTree, model: Abstraction, corrections: Iterable[review.AnyCorrection],
           version: int) -> "Reviewed":
        items = tuple(corrections)
        return cls(tree, model, items, *review.apply(tree, model, list(items)), version)

    def graph(self, name: str) -> rdflib.Graph | None:
        """The corrections as their named graph (review.to_graph), None without any."""
        return review.to_graph(name, list(self.corrections)) if self.corrections else None


def is_corrections_graph(graph: str) -> bool:
    """True for the IRI of a robot's corrections graph, whether or not that robot is stored."""
    return bool((m := _ROBOT_GRAPH.fullmatch(graph)) and m.group(2))


@dataclass(frozen=True)
class BuiltRobot(RobotEntry):
    """A robot as the write that built it returns it: its entry, and `corrections`, what laying the stored
    corrections over the model's answer did (review.Report, as a dict)."""

    corrections: dict = field(compare=False)


class Store:
    """The quadstore file at `path` (created with the core if new), safe to share between threads.

    `workers` query processes answer SPARQL (0: in this process, without a deadline, as most tests do),
    each answer within `limits`; answers are kept until the next write in a cache of `result_cache` bytes (0: none)."""

    def __init__(self, path: str | Path | None = None, workers: int = QUERY_WORKERS, limits: ResultLimits = ResultLimits(),
                 result_cache: int = RESULT_CACHE):
        self.path = Path(path) if path else default_store_path()
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.lock = threading.RLock()
        self._writes = 0  # writes that touched a graph, counted once the index has their graphs
        self._versions: dict[str, int] = {}  # robot name -> writes that touched its graphs (what a cache is of)
        self._reviews: dict[str, Reviewed] = {}  # `reviewed` kept, oldest first
        self._fresh: dict[str, Reviewed] = {}  # what the write under way made of a robot, kept once it commits
        self._exports: dict[tuple[str, str], bytes] = {}  # (robot, extension) -> export, oldest first
        self._exporting: dict[tuple[str, str], threading.Lock] = {}  # one export of each at a time
        self._export_guard = threading.Lock()  # over _exporting
        self._open()
        self._refuse_robots_without_source()
        with self.lock:
            self._entries = self._read_entries()
            graphs = {CORE_GRAPH: rdf.ntriples(self.core)}
            for e in self.robots():
                graphs[e.ontology_iri] = rdf.ntriples(self._ontology(e.ontology_iri))
            for iri, onto in list(self.world.ontologies.items()):  # a robot's, or left by an update that dropped it
                if is_corrections_graph(iri):
                    graphs[iri] = rdf.ntriples(onto)
            for graph, data in self.db.execute("SELECT graph, ntriples FROM kb_graphs").fetchall():
                if is_corrections_graph(graph):  # no longer written (`update` refuses them): the world holds them
                    self.db.execute("DELETE FROM kb_graphs WHERE graph=?", (graph,))
                else:
                    graphs[graph] = data
            self.world.save()
        self.index = Index(graphs, workers, limits, result_cache)

    def _open(self) -> None:
        self.world = rdf.open_world(self.path)
        self.db = rdf.database(self.world)  # the store's own tables, written in the world's transactions
        self.core = load_core(self.world)
        for statement in _SCHEMA:
            self.db.execute(statement)
        self.world.save()

    def _refuse_robots_without_source(self) -> None:
        """UrdfkbError naming the robots stored without their URDF tree and model answer (table kb_sources), as
        development versions before reviewers' corrections wrote them: no release did, and without the URDF
        (its origins, limits, geometry) they cannot be migrated."""
        names = [row[0] for row in self.db.execute(
            "SELECT name FROM kb_robots WHERE name NOT IN (SELECT name FROM kb_sources) ORDER BY name")]
        if names:
            self.world.close()
            raise UrdfkbError(
                f"the store {self.path} holds robots written by a development version of urdfkb without their URDF "
                f"tree: {', '.join(names)}. Populate them again from their URDF files into a new store (urdfkb serve "
                "--store NEW.sqlite3 --populate ROBOT.urdf, or POST /populate), and remove this file")

    def _discard(self) -> None:
        """Drop uncommitted changes and the world's in-memory caches; reopen from the file."""
        self.db.rollback()
        self.world.close()
        self._open()

    @contextmanager
    def _writing(self):
        """One write transaction; yields a set the writer adds every graph IRI it touches to. A write the disk
        refuses raises its storage_fault."""
        touched: set[str] = set()
        with self.lock, self._faults_named():
            committed = False
            try:
                yield touched
                self.world.save()
                committed = True
            except BaseException:
                self._discard()
                raise
            finally:
                self._sync_graphs(touched)
                self._entries = self._read_entries()
                self._writes += bool(touched)
                self._forget(touched, committed)

    def _forget(self, graphs: set[str], committed: bool) -> None:
        """(Under the lock, after a write) drop what is kept of the robots whose graphs the write touched, count
        the write in their versions, and keep what a committed write made of them (`_fresh`)."""
        for name in {m.group(1) for g in graphs if (m := _ROBOT_GRAPH.fullmatch(g))}:
            self._versions[name] = self._versions.get(name, 0) + 1
            self._reviews.pop(name, None)
            for ext in BY_EXTENSION:
                self._exports.pop((name, ext), None)
        fresh, self._fresh = self._fresh, {}
        for name, made in fresh.items() if committed else ():
            self._keep(self._reviews, name, replace(made, version=self._versions.get(name, 0)), KEPT_REVIEWS)

    @staticmethod
    def _keep(kept: dict, key, value, most: int, size=lambda v: 1) -> None:
        """(Under the lock) put `value` in `kept` as its newest, dropping the oldest past `most` (in `size`)."""
        kept.pop(key, None)
        kept[key] = value
        while sum(map(size, kept.values())) > most and len(kept) > 1:
            kept.pop(next(iter(kept)))

    @contextmanager
    def _faults_named(self):
        """SQLite's refusal of a write as its storage_fault, logged as the operator's to fix (no traceback)."""
        try:
            yield
        except sqlite3.OperationalError as e:
            if (fault := storage_fault(e, self.path)) is None:
                raise
            log.error("store write refused: %s", fault)
            raise fault from e

    def _sync_graphs(self, graphs: set[str]) -> None:
        """Copy `graphs` from the quadstore (as committed) into the SPARQL index."""
        self.index.put({g: self._graph_data(g) for g in graphs})

    def _graph_data(self, graph: str) -> bytes | None:
        """A graph's N-Triples as stored: the core, a robot's ontology, or a kb_graphs row (None: no such graph)."""
        if graph == CORE_GRAPH:
            return rdf.ntriples(self.core)
        row = self.db.execute("SELECT name FROM kb_robots WHERE ontology_iri=?", (graph,)).fetchone()
        if row:
            return rdf.ntriples(self._ontology(graph))
        if is_corrections_graph(graph):  # a robot's corrections, kept in the world only
            onto = self.world.ontologies.get(graph)
            return rdf.ntriples(onto) if onto is not None else None
        row = self.db.execute("SELECT ntriples FROM kb_graphs WHERE graph=?", (graph,)).fetchone()
        return row[0] if row else None

    def close(self) -> None:
        self.index.close()
        with self.lock:
            self.world.close()

    # --- robots -------------------------------------------------------------------------------

    def robots(self) -> list[RobotEntry]:
        """The stored robots by name, as of the last write (without the lock: never waits for a write)."""
        return list(self._entries.values())

    def robot(self, name: str) -> RobotEntry | None:
        """Robot `name` as of the last write (without the lock), or None."""
        return self._entries.get(name)

    def require(self, name: str) -> RobotEntry:
        """Robot `name` as robot() gives it; UnknownRobot if there is none."""
        if (entry := self.robot(name)) is None:
            raise UnknownRobot(name)
        return entry

    def _read_entries(self) -> dict[str, RobotEntry]:
        """(Under the lock) table kb_robots as committed, by name: the snapshot robots() and robot() read."""
        rows = self.db.execute("SELECT * FROM kb_robots ORDER BY name").fetchall()
        return {row[0]: RobotEntry(*row) for row in rows}

    def replace_robot(self, name: str, tree: KinematicTree, abstraction: Abstraction | None,
                      provenance: dict[str, str] | None = None) -> BuiltRobot:
        """Write robot `name` (replacing any earlier one) in one transaction; all or nothing.

        Reviewers' corrections stored for `name` are laid over the abstraction; the entry's
        `corrections` says which applied and which no longer fit."""
        check_robot_name(name)
        abstraction = abstraction or Abstraction()
        model = abstraction.with_provenance(provenance or {})
        source = (name, json.dumps(tree.to_dict()), json.dumps(model.to_dict()))
        with self.lock:
            version, items = self._versions.get(name, 0), self._corrections(name)
        made = Reviewed.of(tree, model, items, version)  # outside the lock
        with self._writing() as touched:
            if self._versions.get(name, 0) != version:  # the corrections changed meanwhile
                made = Reviewed.of(tree, model, self._corrections(name), version)
            self.db.execute("INSERT OR REPLACE INTO kb_sources VALUES (?,?,?)", source)
            return self._build(name, made, touched)

    def _build(self, name: str, made: Reviewed, touched: set[str]) -> BuiltRobot:
        """(Inside _writing) the robot graph of `made` (the model's answer with the corrections laid over it),
        checked against the SHACL shapes as the command line checks what it writes: ShapeError (the
        transaction rolls back) if it breaks them."""
        onto = build_robot(self.world, made.tree, name, made.corrected)
        touched.add(onto.base_iri)
        self.db.execute("DELETE FROM kb_graphs WHERE graph=?", (onto.base_iri,))
        rdf.add_object_triples(onto, str(PROV.wasInfluencedBy), review.influences(onto.base_iri, name, made.report))
        broken = violations(robot_graph(onto, made.graph(name)))
        if broken:
            raise ShapeError(f"robot {name!r} breaks the SHACL shapes, so it was not stored: {'; '.join(broken)}", broken)
        robot_cls = self.world[CORE_IRI + "Robot"]
        (robot,) = [i for i in onto.individuals() if robot_cls in i.is_a]
        entry = BuiltRobot(name, onto.base_iri, robot.iri, datetime.now(timezone.utc).isoformat(timespec="seconds"),
                           made.report.to_dict())
        self.db.execute("INSERT OR REPLACE INTO kb_robots VALUES (?,?,?,?)",
                        (entry.name, entry.ontology_iri, entry.robot_iri, entry.updated))
        self._fresh[name] = made
        return entry

    # --- reviewers' corrections (graph review.corrections_iri(name)) ----------------------------

    def source(self, name: str) -> tuple[KinematicTree, Abstraction]:
        """The tree and the model's own abstraction robot `name` was last populated from (kept while an update
        that emptied its graph has it out of robots()); UnknownRobot for a robot never stored, or deleted."""
        with self.lock:
            row = self._source_row(name)
        return _decoded(row)

    def _source_row(self, name: str) -> tuple[str, str]:
        row = self.db.execute("SELECT tree, abstraction FROM kb_sources WHERE name=?", (name,)).fetchone()
        if row is None:
            raise UnknownRobot(name)
        return row

    def corrections(self, name: str) -> list[review.AnyCorrection]:
        """Robot `name`'s stored corrections, oldest first."""
        with self.lock:
            return self._corrections(name)

    def reviewed(self, name: str) -> Reviewed:
        """Robot `name` as `source` gives it, its corrections and what they make of it: computed once per write
        of the robot (the lock held only to read the source and the corrections), then kept."""
        if (kept := self._reviews.get(name)) is not None:
            return kept
        with self.lock:
            version, row, items = self._versions.get(name, 0), self._source_row(name), self._corrections(name)
        made = Reviewed.of(*_decoded(row), items, version)
        with self.lock:
            if self._versions.get(name, 0) == version:
                self._keep(self._reviews, name, made, KEPT_REVIEWS)
        return made

    def _corrections(self, name: str) -> list[review.AnyCorrection]:
        onto = self.world.ontologies.get(review.corrections_iri(name))
        if onto is None:
            return []
        return review.from_graph(rdf.rdflib_graph(onto))

    def _write_corrections(self, name: str, items: list[review.AnyCorrection]) -> None:
        iri = review.corrections_iri(name)
        if (old := self.world.ontologies.get(iri)) is not None:
            old.destroy()
        if items:
            rdf.load_graph(self.world, iri, review.to_graph(name, items))

    def add_correction(self, name: str, correction: review.AnyCorrection) -> BuiltRobot:
        """Store `correction` (a body correction naming its parts by their joints: review.resolve), or raise
        CorrectionError if it does not fit the robot as it is now or the robot it would make breaks the SHACL
        shapes, UnknownRobot if the robot is unknown; and rebuild the robot graph with it, in one transaction.
        Writes the robot's graph and its corrections graph."""
        self.require(name)
        current = self.reviewed(name)
        made = _with(current, correction)  # checked and laid over the robot outside the lock
        with self._writing() as touched:
            self.require(name)
            if self._versions.get(name, 0) != current.version:  # a write of this robot landed meanwhile
                made = _with(self.reviewed(name), correction)
            touched.add(review.corrections_iri(name))
            self._write_corrections(name, list(made.corrections))
            try:
                return self._build(name, made, touched)
            except ShapeError as e:  # the transaction rolls back: nothing stored changes
                raise review.CorrectionError("the robot this correction makes breaks the SHACL shapes, so it was not "
                                             f"stored: {'; '.join(e.violations)}") from None

    def delete_robot(self, name: str) -> RobotEntry | None:
        """Remove robot `name`; returns what was removed, None if there was no such robot."""
        with self._writing() as touched:
            entry = self.robot(name)
            if entry is None:
                return None
            touched.update((entry.ontology_iri, review.corrections_iri(name)))
            self._unregister(entry)
            self._write_corrections(name, [])
            self.db.execute("DELETE FROM kb_sources WHERE name=?", (name,))
        return entry

    def _unregister(self, entry: RobotEntry) -> None:
        self._ontology(entry.ontology_iri).destroy()
        self.db.execute("DELETE FROM kb_robots WHERE name=?", (entry.name,))

    def _ontology(self, iri: str) -> rdf.Ontology:
        return self.world.ontologies.get(iri) or self.world.get_ontology(iri)

    def _corrections_graph(self, name: str) -> rdflib.Graph | None:
        items = self._corrections(name)
        return review.to_graph(name, items) if items else None

    def _snapshot(self, name: str) -> tuple[int, rdflib.Graph] | None:
        """Robot `name`'s version and its `robot_graph`, built from its graph and its corrections graph as the SPARQL
        index holds them after the last committed write: read without the store lock, so an export never waits
        for a write in progress (a long correction of another robot). None if there is no such robot."""
        if (entry := self.robot(name)) is None:
            return None
        version = self._versions.get(name, 0)  # read first: a write landing meanwhile makes the export unkept
        if (data := self.index.graph(entry.ontology_iri)) is None:
            return None
        corrections = self.index.graph(review.corrections_iri(name))
        items = review.from_graph(rdf.parse_ntriples(corrections)) if corrections else []
        return version, robot_graph_of(data, entry.ontology_iri, review.to_graph(name, items) if items else None)

    def graph(self, name: str) -> rdflib.Graph | None:
        """The robot, its corrections and the core as one self-contained in-memory graph (for mirrors)."""
        snapshot = self._snapshot(name)
        return snapshot[1] if snapshot else None

    def export(self, name: str, ext: str) -> bytes | None:
        """The robot as a file (`ext` a key of formats.BY_EXTENSION) that opens in Protégé offline: made
        outside the store lock from a snapshot, once per write of the robot (clients asking meanwhile wait
        for it), and kept until a write touches the robot."""
        key = (name, ext)
        if self.robot(name) is None:  # before a lock is made for the name
            return None
        with self._export_guard:
            making = self._exporting.setdefault(key, threading.Lock())
        with making:
            if (kept := self._exports.get(key)) is not None:
                return kept
            if (snapshot := self._snapshot(name)) is None:
                return None
            buf = io.BytesIO()
            export_graph(snapshot[1], buf, BY_EXTENSION[ext].name)
            data = buf.getvalue()
            with self.lock:
                if self._versions.get(name, 0) == snapshot[0]:
                    self._keep(self._exports, key, data, KEPT_EXPORT_BYTES, len)
        return data

    # --- SPARQL -------------------------------------------------------------------------------

    def query(self, text: str, timeout: float = QUERY_TIMEOUT, accept: str | None = None,
              default_graphs: list[str] | None = None, named_graphs: list[str] | None = None,
              fresh: bool = False) -> Result:
        """Run a SPARQL query over everything stored, or take its answer from the result cache unless `fresh`
        (see Index.query); never waits for writers."""
        return self.index.query(text, accept, timeout, default_graphs, named_graphs, fresh)

    def submit_query(self, text: str, timeout: float, accept: str | None, default_graphs: list[str] | None,
                     named_graphs: list[str] | None, done: Done) -> None:
        """`query` evaluated by a worker (Index.submit_query: look in `index.cached` first) and answered through
        `done(result, error)`, called from the index's answering thread (Index.submit)."""
        self.index.submit_query(text, accept, timeout, default_graphs, named_graphs, done)

    def update(self, text: str, timeout: float = QUERY_TIMEOUT) -> None:
        """Apply a SPARQL update atomically: Oxigraph evaluates it on one replica, the graphs it changed
        are written to the quadstore in one transaction, and the index then takes them from there.

        The core and the corrections graphs (every robot's, stored or dropped) are read-only: an update that
        would change one raises ReadOnlyGraph, except CLEAR/DROP ALL and NAMED, which mean "every writable
        graph" and leave them. A robot graph an update empties is no longer a robot (it leaves /robots); its
        source and corrections stay, read-only, and apply again when it is populated again.

        The evaluation, and the wait for a free worker before it, hold no lock; the transaction then
        checks that no write landed in between, and evaluates again if one did, so the update applies
        to exactly the state it read (all within `timeout`)."""
        deadline = time.monotonic() + timeout
        while True:
            seen = self._writes
            changes = self.index.update(text, max(deadline - time.monotonic(), 0.0))
            with self._writing() as touched:
                if self._writes != seen:
                    if time.monotonic() >= deadline:
                        raise QueryTimeout(f"the store kept changing under this update for its {timeout:g} s timeout")
                    continue
                accepted = set(changes)
                protected = {g for g in accepted if g == CORE_GRAPH or is_corrections_graph(g)}
                if protected:
                    found = scan(text, update=True).keywords
                    if not (found & {"CLEAR", "DROP"} and found & {"ALL", "NAMED"}):
                        raise ReadOnlyGraph(f"graph <{sorted(protected)[0]}> is read-only to SPARQL Update "
                                            "(the core ontology; reviewers' corrections go through /robots/<name>/corrections)")
                    accepted -= protected
                for graph in accepted:
                    self._check_shapes(graph, changes[graph][1])
                for graph in accepted:
                    self._persist(graph, changes[graph][1])
                touched.update(accepted)
                return

    def _check_shapes(self, graph: str, data: bytes | None) -> None:
        """The SHACL gate every write passes, for an update's new content of a robot graph: ShapeError
        (nothing is written) if it breaks the shapes. An update that empties a robot graph removes the robot."""
        row = self.db.execute("SELECT name FROM kb_robots WHERE ontology_iri=?", (graph,)).fetchone()
        if row is None or not data:
            return
        broken = violations(robot_graph_of(data, graph, self._corrections_graph(row[0])))
        if broken:
            raise ShapeError(f"this update would make robot {row[0]!r} break the SHACL shapes, so nothing was "
                             f"written: {'; '.join(broken)}", broken)

    def _persist(self, graph: str, data: bytes | None) -> None:
        """Store one graph's new content: into the robot's ontology, or as a kb_graphs row."""
        db = self.db
        row = db.execute("SELECT name FROM kb_robots WHERE ontology_iri=?", (graph,)).fetchone()
        if row is None:
            if data is None:
                db.execute("DELETE FROM kb_graphs WHERE graph=?", (graph,))
            else:
                db.execute("INSERT OR REPLACE INTO kb_graphs VALUES (?, ?)", (graph, data))
            return
        self._ontology(graph).destroy()
        if not data:
            db.execute("DELETE FROM kb_robots WHERE name=?", row)
            if data is not None:  # cleared, not dropped: the empty graph stays
                db.execute("INSERT OR REPLACE INTO kb_graphs VALUES (?, ?)", (graph, b""))
            return
        rdf.load_ntriples(self.world, graph, data)


def _decoded(row: tuple[str, str]) -> tuple[KinematicTree, Abstraction]:
    """A kb_sources row's tree and model abstraction."""
    return KinematicTree.from_dict(json.loads(row[0])), Abstraction.from_dict(json.loads(row[1]))


def _with(current: Reviewed, correction: review.AnyCorrection) -> Reviewed:
    """`current` with one more correction (resolved: review.resolve); CorrectionError unless it applies."""
    correction = review.resolve(current.corrected, correction)
    review.check(current.tree, current.corrected, correction)
    return Reviewed.of(current.tree, current.model, (*current.corrections, correction), current.version)
