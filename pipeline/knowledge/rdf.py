"""The one seam between urdfkb's RDF libraries: the only module that imports owlready2 or calls its internals.

Three libraries hold RDF, each for what only it does well here:

- **owlready2** is the store of record and the model population writes through: an OWL object model
  (the core's classes and properties as Python objects), a quadstore in SQLite with transactions (one
  ontology per named graph, the store's own tables beside it in the same file), and HermiT, bundled
  with its Java classpath, for the classifications of pipeline.knowledge.reasoning.
- **rdflib** is what pySHACL validates and what writes the export formats (pipeline.knowledge.shacl,
  pipeline.knowledge.export, pipeline.knowledge.formats); the vocabulary and the reviewers' corrections are read and
  written as rdflib graphs (pipeline.knowledge.ontology, kb_server.corrections).
- **Oxigraph** (pyoxigraph) answers SPARQL 1.1, queries and updates, in worker processes
  (kb_server.index, kb_server.sparql): owlready2's own engine fails much of the W3C suite (docs/sparql.md).

They meet in **N-Triples**: a line per triple, no prefixes, no nesting, which every one of them reads
and writes. A graph leaves owlready2 as N-Triples (`ntriples`), which rdflib parses (`parse_ntriples`,
`rdflib_graph`) and the Oxigraph index loads as it is; a graph enters owlready2 from N-Triples
(`load_ntriples`, `load_graph`), as a SPARQL update's result and the corrections graph do. Every such
conversion is here, and so is every call of owlready2's private API (triples by store id, the SQLite
connection), so the rest of the code uses owlready2's public objects only (`world[iri]`,
`onto.individuals()`, `prop[subject].append(value)`, `world.save()`, `onto.destroy()`...) and the
functions below; tests/test_layout.py checks both.
"""
from __future__ import annotations

import io
import sqlite3
import types
from pathlib import Path
from typing import Any, Iterable

import owlready2
import rdflib
from owlready2 import Ontology, Thing, World  # types the other modules annotate with (rdf.World...)

# --- worlds -------------------------------------------------------------------------------------


def new_world() -> World:
    """An empty world in memory (a populate to a file, a reasoner run)."""
    return owlready2.World()


def open_world(path: str | Path) -> World:
    """The quadstore file at `path` (created if missing), opened so that other processes can read it
    while this one writes (`urdfkb query` beside a running server): shared, write-ahead log."""
    return owlready2.World(filename=str(path), exclusive=False, journal_mode="WAL")


def database(world: World) -> sqlite3.Connection:
    """The SQLite connection of `world`'s quadstore: tables beside owlready2's are written in its
    transactions, which `world.save()` commits."""
    return world.graph.db


# --- graphs as N-Triples, in and out of owlready2 and rdflib --------------------------------------


def ntriples(onto: Ontology) -> bytes:
    """The triples of ontology `onto` (its named graph) as N-Triples."""
    buf = io.BytesIO()
    onto.save(buf, format="ntriples")
    return buf.getvalue()


def parse_ntriples(data: bytes) -> rdflib.Graph:
    """N-Triples as an rdflib graph."""
    return rdflib.Graph().parse(data=data, format="nt")


def rdflib_graph(onto: Ontology) -> rdflib.Graph:
    """The triples of ontology `onto` as an rdflib graph (a copy: changing it leaves `onto` as it is)."""
    return parse_ntriples(ntriples(onto))


def to_ntriples(graph: rdflib.Graph) -> bytes:
    """An rdflib graph as N-Triples."""
    return graph.serialize(format="nt", encoding="utf-8")


def load_ntriples(world: World, iri: str, data: bytes) -> Ontology:
    """Ontology `iri` of `world` (its named graph), with the N-Triples `data` added (to a new one:
    destroy an earlier one first)."""
    return world.get_ontology(iri).load(fileobj=io.BytesIO(data), format="ntriples")


def load_graph(world: World, iri: str, graph: rdflib.Graph) -> Ontology:
    """`load_ntriples` of an rdflib graph."""
    return load_ntriples(world, iri, to_ntriples(graph))


# --- triples by IRI, below owlready2's object model ------------------------------------------------


def add_object_triples(onto: Ontology, predicate: str, pairs: Iterable[tuple[str, str]]) -> None:
    """Add (subject, `predicate`, object) to `onto` for each IRI pair, whatever the IRIs' types
    (a predicate the core does not declare, such as prov:wasInfluencedBy, included)."""
    world = onto.world
    p = world._abbreviate(predicate)
    for s, o in pairs:
        onto._add_obj_triple_spo(world._abbreviate(s), p, world._abbreviate(o))


def ontology_value(onto: Ontology, predicate: str) -> object | None:
    """The value `onto` states of itself with data property `predicate` (its IRI), or None."""
    p = onto.world._abbreviate(predicate, False)
    if p is None:
        return None
    value = onto._get_data_triple_sp_od(onto.storid, p)
    return value[0] if value else None


def set_ontology_value(onto: Ontology, predicate: str, value: object) -> None:
    """Make `value` the one value `onto` states of itself with data property `predicate` (its IRI)."""
    p = onto.world._abbreviate(predicate)
    onto._del_data_triple_spod(onto.storid, p, None, None)
    onto._add_data_triple_spod(onto.storid, p, *owlready2.to_literal(value))


# --- what the object model answers by owlready2's classes -----------------------------------------


def is_annotation_property(entity: object) -> bool:
    """Whether `entity` (as `world[iri]` gives it) is an annotation property."""
    return isinstance(entity, owlready2.AnnotationPropertyClass)


def class_iris(entity: Thing) -> list[str]:
    """The IRIs of the named classes among what `entity` is asserted or inferred to be (its `is_a`)."""
    return [c.iri for c in entity.is_a if isinstance(c, owlready2.ThingClass)]


def all_different(individuals: list) -> None:
    """State that `individuals` are pairwise different (owl:AllDifferent), in the ontology in `with`."""
    owlready2.AllDifferent(individuals)


def complement_class(name: str, cls: object) -> str:
    """The IRI of a new class `name`, in the ontology in `with`, defined as everything that is not a `cls`
    (owl:complementOf): HermiT puts in it each individual that cannot be a `cls` (see class_iris)."""
    negation: Any = types.new_class(name, (Thing,))
    negation.equivalent_to = [owlready2.Not(cls)]
    return negation.iri


def hermit(world: World) -> str | None:
    """Classify `world` with HermiT, asserting the classes it infers; None when it ran, or what kept it
    from running (no Java, HermiT failed)."""
    try:
        owlready2.sync_reasoner_hermit(world, infer_property_values=False, debug=0)
    except (owlready2.OwlReadyJavaError, OSError) as e:
        return str(e)
    return None
