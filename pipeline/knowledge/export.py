"""Export a populated robot as one self-contained RDF file (core axioms merged in, no owl:imports)."""
from __future__ import annotations

import functools
import os
from typing import BinaryIO

import rdflib
from rdflib.namespace import OWL, SOSA

from urdfkb.pipeline.knowledge import rdf
from urdfkb.pipeline.atomic import write_atomically
from urdfkb.pipeline.errors import OntologyError
from urdfkb.pipeline.knowledge.formats import BY_NAME
from urdfkb.pipeline.knowledge.namespaces import CORE_IRI, CORE_ONTOLOGY_IRI
from urdfkb.pipeline.knowledge.ontology import Vocabulary, vocabulary


@functools.cache
def _core_triples(vocab: Vocabulary) -> tuple:
    """The core's triples without its ontology header (the export has one header: the robot's)."""
    header = rdflib.URIRef(CORE_ONTOLOGY_IRI)
    return tuple(t for t in vocab.graph if t[0] != header)


def robot_graph(onto: rdf.Ontology, extra: rdflib.Graph | None = None,
                vocab: Vocabulary | None = None) -> rdflib.Graph:
    """The robot ontology's own triples plus the core's axioms (of `vocab`, the packaged vocabulary by
    default) and `extra` (e.g. reviewers' corrections), as one rdflib graph."""
    return robot_graph_of(rdf.ntriples(onto), onto.base_iri, extra, vocab)


def robot_graph_of(ntriples: bytes, base_iri: str, extra: rdflib.Graph | None = None,
                   vocab: Vocabulary | None = None) -> rdflib.Graph:
    """`robot_graph` of a robot graph given as N-Triples (its ontology IRI `base_iri`)."""
    graph = rdf.parse_ntriples(ntriples)
    for triple in _core_triples(vocab or vocabulary()):
        graph.add(triple)
    if extra is not None:
        graph += extra
        for prefix, ns in extra.namespaces():
            if prefix in ("prov", "review"):
                graph.bind(prefix, ns)
    graph.remove((None, OWL.imports, None))
    graph.bind("core", CORE_IRI)
    graph.bind("robot", base_iri)
    graph.bind("sosa", SOSA)
    return graph


def export_robot(onto: rdf.Ontology, dest: str | os.PathLike | BinaryIO, fmt: str = "rdfxml",
                 extra: rdflib.Graph | None = None) -> None:
    """Write `robot_graph(onto, extra)` to a path (atomically: temp file then rename) or a binary stream."""
    if fmt not in BY_NAME:
        raise OntologyError(f"unknown export format {fmt!r}; choose one of {', '.join(BY_NAME)}")
    export_graph(robot_graph(onto, extra), dest, fmt)


def export_graph(graph: rdflib.Graph, dest: str | os.PathLike | BinaryIO, fmt: str = "rdfxml") -> None:
    """Write a graph `robot_graph` built (and SHACL checked, say) as export_robot would."""
    if fmt not in BY_NAME:
        raise OntologyError(f"unknown export format {fmt!r}; choose one of {', '.join(BY_NAME)}")
    data = graph.serialize(format=BY_NAME[fmt].rdflib, encoding="utf-8")
    if hasattr(dest, "write"):
        dest.write(data)
        return
    write_atomically(dest, data, mode=0o644)
