"""Check a populated robot graph against ontologies/shapes.ttl, with the core mixed in.

Class targets reach subclasses through the core's rdfs:subClassOf triples (SHACL instances), so no
RDFS inference pass is needed. Both graphs are the Vocabulary's own (parsed once per process).
"""
from __future__ import annotations

import pyshacl
import rdflib

from urdfkb.pipeline.ontology import Vocabulary, vocabulary


def validate(data: rdflib.Graph, vocab: Vocabulary | None = None) -> tuple[bool, str]:
    """(conforms, human-readable report) against `vocab`'s shapes (the packaged ones by default);
    `data` itself is left unchanged."""
    vocab = vocab or vocabulary()
    conforms, _, text = pyshacl.validate(
        data, shacl_graph=vocab.shapes, ont_graph=vocab.graph, inference="none", abort_on_first=False,
    )
    return bool(conforms), text
