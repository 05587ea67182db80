"""Check a populated robot graph against ontologies/shapes.ttl, with the core mixed in.

Class targets reach subclasses through the core's rdfs:subClassOf triples (SHACL instances), so no
RDFS inference pass is needed: that keeps the gate at about 0.1 s for a 100-link robot.
"""
from __future__ import annotations

import functools
import importlib.resources

import pyshacl
import rdflib

from urdfkb.pipeline.ontology import core_path


@functools.cache
def _shapes() -> rdflib.Graph:
    return rdflib.Graph().parse(str(importlib.resources.files("urdfkb.ontologies").joinpath("shapes.ttl")), format="turtle")


@functools.cache
def _core() -> rdflib.Graph:
    return rdflib.Graph().parse(core_path(), format="xml")


def validate(data: rdflib.Graph) -> tuple[bool, str]:
    """(conforms, human-readable report); `data` itself is left unchanged."""
    conforms, _, text = pyshacl.validate(
        data, shacl_graph=_shapes(), ont_graph=_core(), inference="none", abort_on_first=False,
    )
    return bool(conforms), text
