"""Check a populated robot graph against ontologies/shapes.ttl, with the core mixed in.

Class targets reach subclasses through the core's rdfs:subClassOf triples (SHACL instances), so no
RDFS inference pass is needed. Both graphs are the Vocabulary's own (parsed once per process).
"""
from __future__ import annotations

from dataclasses import dataclass

import pyshacl
import rdflib
from rdflib.namespace import RDF, RDFS, SH

from urdfkb import local_name
from urdfkb.pipeline.knowledge.ontology import Vocabulary, vocabulary


def validate(data: rdflib.Graph, vocab: Vocabulary | None = None) -> tuple[bool, str]:
    """(conforms, human-readable report) against `vocab`'s shapes (the packaged ones by default);
    `data` itself is left unchanged."""
    conforms, _, text = _run(data, vocab or vocabulary())
    return conforms, text


@dataclass(frozen=True)
class Violation:
    """One constraint `focus` breaks: the node shape it falls under, the property path, the message."""

    shape: str
    focus: rdflib.term.Node | None
    path: rdflib.term.Node | None
    message: str

    def __str__(self) -> str:
        """As violations() lists it: "CameraShape: comp_x hasComponent: a camera needs ..." """
        where = " ".join(local_name(n) for n in (self.focus, self.path) if isinstance(n, rdflib.URIRef))
        return f"{self.shape}: {where}: {self.message}"


def violations(data: rdflib.Graph, vocab: Vocabulary | None = None) -> list[str]:
    """One line per violation, naming the shape, the node and why ("CameraShape: comp_x hasComponent: a camera
    needs ..."); empty when `data` conforms."""
    return sorted(map(str, broken(data, vocab)))


def broken(data: rdflib.Graph, vocab: Vocabulary | None = None) -> list[Violation]:
    """Every violation of `vocab`'s shapes in `data` (none when it conforms)."""
    vocab = vocab or vocabulary()
    conforms, results, _ = _run(data, vocab)
    found = []
    for result in [] if conforms else results.subjects(RDF.type, SH.ValidationResult):
        source = results.value(result, SH.sourceShape)
        shape = vocab.shapes.value(predicate=SH.property, object=source) or source  # a property shape's node shape
        found.append(Violation(local_name(str(shape)), results.value(result, SH.focusNode),
                               results.value(result, SH.resultPath), str(results.value(result, SH.resultMessage))))
    return found


def _run(data: rdflib.Graph, vocab: Vocabulary) -> tuple[bool, rdflib.Graph, str]:
    """pyshacl over `data`, mixing the core in only where `data` lacks it: a graph pipeline.knowledge.export built
    holds the core's axioms already, and mixing copies the whole data graph first (most of a small robot's
    check)."""
    ontology = None if _holds_core(data, vocab) else vocab.graph
    conforms, results, text = pyshacl.validate(
        data, shacl_graph=vocab.shapes, ont_graph=ontology, inference="none", abort_on_first=False,
    )
    return bool(conforms), results, text


def _holds_core(data: rdflib.Graph, vocab: Vocabulary) -> bool:
    """Every rdfs:subClassOf axiom of the core is in `data` (what class targets follow)."""
    return all(t in data for t in vocab.graph.triples((None, RDFS.subClassOf, None)))
