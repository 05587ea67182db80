"""The core ontology: where it lives, how to load it into a World, and its class taxonomy.

The OWL file `ontologies/urdfkb.owl` is the single source of truth; `Taxonomy` is a read-only
view of its named classes used by the stages (labels, definitions, sibling order).
"""
from __future__ import annotations

import functools
import hashlib
import importlib.resources
import pathlib
import xml.etree.ElementTree as ET
from typing import Iterable

import owlready2
import rdflib
from rdflib.namespace import OWL, RDF, RDFS, SKOS

from urdfkb.pipeline.errors import OntologyError

CORE_IRI = "https://w3id.org/urdfkb/core#"
CORE_ONTOLOGY_IRI = CORE_IRI[:-1]
_LOADED_MARK = CORE_IRI + "ontologyVersion"
_SIM_TYPE = rdflib.URIRef(CORE_IRI + "simulatorSensorType")


def core_path() -> pathlib.Path:
    """Path of the packaged core ontology (RDF/XML)."""
    return pathlib.Path(str(importlib.resources.files("urdfkb.ontologies").joinpath("urdfkb.owl")))


@functools.cache
def core_version() -> str:
    """Short SHA-256 of the core file: changes whenever the vocabulary does (cache keys)."""
    return hashlib.sha256(core_path().read_bytes()).hexdigest()[:16]


def load_core(world: owlready2.World) -> owlready2.Ontology:
    """Load the core into `world` from the packaged file, offline; no-op if this version is there.

    The loaded version is recorded on the core ontology in the world, so a persistent
    (SQLite) world holding an older core is reloaded in place.
    """
    onto = world.get_ontology(CORE_ONTOLOGY_IRI)
    if _stored_version(world, onto) == core_version():
        return onto
    with core_path().open("rb") as f:
        onto.load(fileobj=f, reload=onto.loaded)
    mark = world._abbreviate(_LOADED_MARK)
    onto._del_data_triple_spod(onto.storid, mark, None, None)
    onto._add_data_triple_spod(onto.storid, mark, *owlready2.to_literal(core_version()))
    return onto


def _stored_version(world: owlready2.World, onto: owlready2.Ontology) -> str | None:
    mark = world._abbreviate(_LOADED_MARK, False)
    if mark is None:
        return None
    value = onto._get_data_triple_sp_od(onto.storid, mark)
    return value[0] if value else None


class Taxonomy:
    """Named classes of the core and their subclass links, in the file's (spec's) order."""

    def __init__(self, path: pathlib.Path):
        graph = rdflib.Graph().parse(path, format="xml")
        self._order = {n: i for i, n in enumerate(_declared_classes(path))}
        self._parents: dict[str, tuple[str, ...]] = {}
        self._children: dict[str, list[str]] = {n: [] for n in self._order}
        self._label: dict[str, str] = {}
        self._answer: dict[str, str] = {}
        self._comment: dict[str, str] = {}
        self._example: dict[str, str] = {}
        self._excluded: dict[str, set[str]] = {}
        self._declared_by: dict[str, set[str]] = {}  # SDF sensor type → classes aligned to it
        for name in self._order:
            node = rdflib.URIRef(CORE_IRI + name)
            parents = sorted((_local(p) for p in graph.objects(node, RDFS.subClassOf) if _local(p)),
                             key=self._order.__getitem__)
            self._parents[name] = tuple(parents)
            for p in parents:
                self._children[p].append(name)
            self._label[name] = str(graph.value(node, RDFS.label) or name)
            self._answer[name] = str(graph.value(node, SKOS.altLabel) or self._label[name])
            self._comment[name] = str(graph.value(node, RDFS.comment) or "")
            self._example[name] = str(graph.value(node, SKOS.example) or "")
            self._excluded[name] = _excluded_parts(graph, node)
            for sim_type in graph.objects(node, _SIM_TYPE):
                self._declared_by.setdefault(str(sim_type).strip().lower(), set()).add(name)
        for kids in self._children.values():
            kids.sort(key=self._order.__getitem__)

    def _check(self, name: str) -> str:
        if name not in self._order:
            raise OntologyError(f"unknown ontology class {name!r}")
        return name

    def __contains__(self, name: object) -> bool:
        return name in self._order

    def subclasses(self, name: str) -> tuple[str, ...]:
        """Direct named subclasses, in the file's order."""
        return tuple(self._children[self._check(name)])

    def subclasses_below(self, name: str) -> tuple[str, ...]:
        """Every named class under `name`, in the file's order."""
        return tuple(c for c in self._order if c != name and name in self.ancestors(c))

    def parents(self, name: str) -> tuple[str, ...]:
        """Direct named core superclasses (alignment classes such as sosa:Sensor excluded)."""
        return self._parents[self._check(name)]

    def ancestors(self, name: str) -> tuple[str, ...]:
        """All core superclasses, nearest first, without `name` itself."""
        seen: list[str] = []
        frontier = list(self.parents(name))
        while frontier:
            current = frontier.pop(0)
            if current not in seen:
                seen.append(current)
                frontier.extend(self._parents[current])
        return tuple(seen)

    def is_a(self, name: str, ancestor: str) -> bool:
        """True if `name` is `ancestor` or one of its subclasses."""
        return name == self._check(ancestor) or ancestor in self.ancestors(name)

    def is_leaf(self, name: str) -> bool:
        return not self.subclasses(name)

    def label(self, name: str) -> str:
        return self._label[self._check(name)]

    def answer(self, name: str) -> str:
        """The phrase offered to the model for this class: skos:altLabel where given, else the label."""
        return self._answer[self._check(name)]

    def comment(self, name: str) -> str:
        """The class definition shown to the model when it chooses among siblings."""
        return self._comment[self._check(name)]

    def excluded_parts(self, name: str) -> frozenset[str]:
        """Classes a `name` device may not have as sub-components (∀hasComponent.¬X on it or an
        ancestor), with their subclasses."""
        direct = set().union(*(self._excluded[c] for c in (self._check(name), *self.ancestors(name))))
        return frozenset(c for c in self._order if any(self.is_a(c, x) for x in direct))

    def declared_classes(self, sim_types: Iterable[str]) -> frozenset[str]:
        """Classes the ontology aligns to any of these simulator (SDF) sensor types (core:simulatorSensorType)."""
        return frozenset(c for t in sim_types for c in self._declared_by.get(t.strip().lower(), ()))

    def disagreeing(self, declared: frozenset[str], below: str) -> frozenset[str]:
        """Classes under `below` that agree with none of `declared` (neither above nor below one of them):
        what a declaration rules out. Empty when nothing is declared or nothing declared lies under `below`."""
        declared = frozenset(d for d in declared if self.is_a(d, below))
        if not declared:
            return frozenset()
        return frozenset(c for c in self.subclasses_below(below)
                         if not any(self.is_a(c, d) or self.is_a(d, c) for d in declared))

    def example(self, name: str) -> str:
        """An invented link name typical of the class (skos:example), or ''."""
        return self._example[self._check(name)]


def _excluded_parts(graph: rdflib.Graph, node: rdflib.URIRef) -> set[str]:
    """X for each `node ⊑ ∀hasComponent.¬X` axiom."""
    out = set()
    for restriction in graph.objects(node, RDFS.subClassOf):
        if graph.value(restriction, OWL.onProperty) != rdflib.URIRef(CORE_IRI + "hasComponent"):
            continue
        excluded = graph.value(graph.value(restriction, OWL.allValuesFrom), OWL.complementOf)
        if excluded is not None and _local(excluded):
            out.add(_local(excluded))
    return out


def _declared_classes(path: pathlib.Path) -> list[str]:
    """Local names of the core's owl:Class declarations, in document order."""
    tag = "{%s}Class" % OWL
    about = "{%s}about" % RDF
    names = [_local(rdflib.URIRef(el.get(about, ""))) for el in ET.parse(path).getroot().iter(tag)]
    return [n for n in names if n]


def _local(node: rdflib.term.Node) -> str | None:
    """Local name of a core IRI, None for anything else (blank nodes, other namespaces)."""
    text = str(node)
    if isinstance(node, rdflib.URIRef) and text.startswith(CORE_IRI):
        return text[len(CORE_IRI):]
    return None


@functools.cache
def taxonomy() -> Taxonomy:
    """The core's taxonomy, built once per process."""
    return Taxonomy(core_path())
