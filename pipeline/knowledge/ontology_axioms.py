"""The core ontology's class axioms read from its rdflib graph: what a class's restrictions on hasComponent,
on a count or span, and on isLocatedOn say, and core IRIs' local names."""
from __future__ import annotations

from typing import Iterator

import rdflib
from rdflib.collection import Collection
from rdflib.namespace import OWL, RDFS, XSD

from urdfkb.pipeline.errors import OntologyError
from urdfkb.pipeline.knowledge.namespaces import CORE, CORE_IRI


def _on_components(graph: rdflib.Graph, node: rdflib.URIRef, quantifier: rdflib.URIRef) -> Iterator[rdflib.term.Node]:
    """X for each `node ⊑ Q hasComponent.X` axiom whose quantifier Q is `quantifier` (owl:allValuesFrom or
    owl:someValuesFrom)."""
    for restriction in graph.objects(node, RDFS.subClassOf):
        if graph.value(restriction, OWL.onProperty) == CORE.hasComponent:
            if (filler := graph.value(restriction, quantifier)) is not None:
                yield filler


def restricted_parts(graph: rdflib.Graph, node: rdflib.URIRef, complement: bool) -> set[str]:
    """X for each `node ⊑ ∀hasComponent.¬X` axiom (complement), or for each `node ⊑ ∀hasComponent.X`."""
    out = set()
    for filler in _on_components(graph, node, OWL.allValuesFrom):
        part = graph.value(filler, OWL.complementOf) if complement else filler
        if part is not None and (local := local_name(part)):
            out.add(local)
    return out


def needed_parts(graph: rdflib.Graph, node: rdflib.URIRef) -> list[frozenset[str]]:
    """For each `node ⊑ ∃hasComponent.X` axiom, {X}, or the members of X where X is a union."""
    out = []
    for filler in _on_components(graph, node, OWL.someValuesFrom):
        union = graph.value(filler, OWL.unionOf)
        members = list(Collection(graph, union)) if union is not None else [filler]
        out.append(frozenset(filter(None, map(local_name, members))))
    return out


def count_range(graph: rdflib.Graph, node: rdflib.URIRef, prop: rdflib.URIRef) -> tuple[float, float] | None:
    """(least, most) from `node ⊑ ∀prop.integer[>= least, <= most]` (or decimal), None without such an axiom."""
    for restriction in graph.objects(node, RDFS.subClassOf):
        if graph.value(restriction, OWL.onProperty) != prop:
            continue
        low, high = 0.0, float("inf")
        facets = graph.value(graph.value(restriction, OWL.allValuesFrom), OWL.withRestrictions)
        for facet in Collection(graph, facets) if facets is not None else ():
            for kind, value in graph.predicate_objects(facet):
                if kind == XSD.minInclusive:
                    low = float(str(value))
                elif kind == XSD.maxInclusive:
                    high = float(str(value))
                else:
                    raise OntologyError(f"{local_name(node)}: {local_name(prop)} facet {kind} is not minInclusive or maxInclusive")
        return low, high
    return None


def stated_value(graph: rdflib.Graph, node: rdflib.URIRef, prop: rdflib.URIRef) -> str | None:
    """v from `node ⊑ (prop value v)`, None without such an axiom."""
    values = {str(graph.value(r, OWL.hasValue)) for r in graph.objects(node, RDFS.subClassOf)
              if graph.value(r, OWL.onProperty) == prop and graph.value(r, OWL.hasValue) is not None}
    if len(values) > 1:
        raise OntologyError(f"{local_name(node)} states {local_name(prop)} twice: {sorted(values)}")
    return values.pop() if values else None


def placement_of(graph: rdflib.Graph, node: rdflib.URIRef) -> str | None:
    """X, as text, from `node ⊑ ∀isLocatedOn.X`; None without such an axiom."""
    fillers = [graph.value(r, OWL.allValuesFrom) for r in graph.objects(node, RDFS.subClassOf)
               if graph.value(r, OWL.onProperty) == CORE.isLocatedOn]
    if len(fillers) > 1:
        raise OntologyError(f"{local_name(node)} says twice where it is located (∀isLocatedOn)")
    return _expression(graph, fillers[0]) if fillers else None


def _expression(graph: rdflib.Graph, node: rdflib.term.Node | None) -> str:
    """An OWL class expression in DL notation: a named class, or a union, intersection or complement of them."""
    if (local := local_name(node)) is not None:
        return local
    for prop, joiner in ((OWL.unionOf, " ⊔ "), (OWL.intersectionOf, " ⊓ ")):
        if (members := graph.value(node, prop)) is not None:
            return "(" + joiner.join(_expression(graph, m) for m in Collection(graph, members)) + ")"
    if (negated := graph.value(node, OWL.complementOf)) is not None:
        return "¬" + _expression(graph, negated)
    raise OntologyError(f"a class expression urdfkb cannot read: {node!r}")


def local_name(node: rdflib.term.Node | None) -> str | None:
    """Local name of a core IRI, None for anything else (blank nodes, other namespaces)."""
    text = str(node)
    if isinstance(node, rdflib.URIRef) and text.startswith(CORE_IRI):
        return text[len(CORE_IRI):]
    return None
