"""Reading a prediction (../shared/spec/evaluation.md): a populated graph's components and body parts, by the
core namespace and the local names of ../shared/spec/ontology.md only. Class ancestry comes from the graph's own
``rdfs:subClassOf`` triples, and which class roots each kind and its sub-parts from the Vocabulary
(``core:componentKind`` and its ``hasComponent`` branch). Hedging does not pay: an individual with several
incomparable most specific classes has no class (``None``, no credit), one with several ``isMountedOn`` links
has no root.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Iterable, Mapping

import rdflib
from rdflib import RDF, RDFS, URIRef
from rdflib.term import Node

from urdfkb.pipeline.knowledge.namespaces import CORE
from urdfkb.pipeline.knowledge.ontology import vocabulary


@dataclass(frozen=True)
class PredictedBodyPart:
    """A body part as read from a graph: every ``hasJoint`` joint's and ``hasLink`` link's
    ``urdfName`` (unfiltered); ``cls``/``side``/``root`` are None when absent or ambiguous."""

    node: str
    cls: str | None
    side: str | None
    root: str | None
    joints: frozenset[str]
    links: frozenset[str]


@dataclass(frozen=True)
class PredictedComponent:
    """A top-level component as read from a graph; ``cls``/``root`` are None when absent or ambiguous."""

    node: str
    kind: str | None
    cls: str | None
    root: str | None
    leaves: frozenset[str]
    subparts: Mapping[str, str | None] = field(default_factory=dict, hash=False)
    confidence: float | None = None  # its core:confidence, None where the graph gives none


class ClassAncestry:
    """Ancestry over the graph's rdfs:subClassOf triples."""

    def __init__(self, graph: rdflib.Graph):
        self.graph = graph
        self._cache: dict[Node, frozenset[Node | None]] = {}

    def ancestors(self, cls: Node) -> frozenset[Node | None]:
        """Strict superclasses of ``cls``."""
        if cls not in self._cache:
            self._cache[cls] = frozenset(self.graph.transitive_objects(cls, RDFS.subClassOf)) - {cls}
        return self._cache[cls]

    def is_under(self, cls: Node, root: URIRef) -> bool:
        return cls == root or root in self.ancestors(cls)

    def most_specific(self, classes: Iterable[Node]) -> str | None:
        """Local name of the single most specific core class, None if none or several."""
        core = {c for c in classes if isinstance(c, URIRef) and c.startswith(str(CORE))}
        lowest = [c for c in core if not any(c in self.ancestors(o) for o in core if o != c)]
        return lowest[0][len(str(CORE)):] if len(lowest) == 1 else None

    def credit(self, predicted: str | None, accepted: Iterable[str], floors: Iterable[str]) -> float:
        """1 if accepted; 0.5 if a strict ancestor of an accepted class strictly below a floor."""
        accepted = set(accepted)
        if predicted is None:
            return 0.0
        if predicted in accepted:
            return 1.0
        p = CORE[predicted]
        below_floor = any(CORE[f] in self.ancestors(p) for f in floors)
        if below_floor and any(p in self.ancestors(CORE[a]) for a in accepted):
            return 0.5
        return 0.0


def _reach(graph: rdflib.Graph, node, prop: URIRef) -> set:
    """Nodes reached from ``node`` by one or more ``prop`` edges."""
    return set(graph.transitive_objects(node, prop)) - {node}


def kind_roots() -> dict[str, str]:
    """Kind → its class under Component."""
    return {k: kind.cls for k, kind in vocabulary().kinds.items()}


def read_prediction(graph: rdflib.Graph, urdf_leaves: set[str], ancestry: ClassAncestry | None = None
                    ) -> list[PredictedComponent]:
    """The predicted components of ``graph`` (spec: "Reading a prediction").

    Leaves are restricted to ``urdf_leaves``; pass the URDF's leaves minus the truth's
    ``ignore``. A component typed under both Sensor and EndEffector has kind None: it counts
    over both kinds but in neither per-kind scope. Components left with no leaves are kept
    here and dropped by :func:`urdfkb.pipeline.scoring.evaluation.score`. ``ancestry`` (of ``graph``) may be
    shared with another read of the same graph.
    """
    ancestry = ancestry or ClassAncestry(graph)
    roots = kind_roots()

    def names(node) -> set[str]:
        return {str(n) for link in graph.objects(node, CORE.hasLink) for n in graph.objects(link, CORE.urdfName)}

    out = []
    robots = set(graph.subjects(RDF.type, CORE.Robot))
    tops = {c for r in robots for c in graph.objects(r, CORE.hasComponent)}
    for comp in sorted(tops):  # type: ignore[type-var]  # rdflib types objects as Node; these are Identifiers (str)
        types = set(graph.objects(comp, RDF.type))
        kinds = {k for k, root in roots.items() if any(ancestry.is_under(t, CORE[root]) for t in types)}
        if not kinds:
            continue
        subs = _reach(graph, comp, CORE.hasComponent)
        leaves = set(names(comp))
        sub_types: dict[str, set] = {}
        for sub in subs:
            for leaf in names(sub):
                leaves.add(leaf)
                sub_types.setdefault(leaf, set()).update(graph.objects(sub, RDF.type))
        leaves &= urdf_leaves
        mounts = {str(n) for link in graph.objects(comp, CORE.isMountedOn) for n in graph.objects(link, CORE.urdfName)}
        confidence = graph.value(comp, CORE.confidence)
        out.append(PredictedComponent(
            node=str(comp),
            kind=kinds.pop() if len(kinds) == 1 else None,
            cls=ancestry.most_specific(t for t in types if any(ancestry.is_under(t, CORE[r]) for r in roots.values())),
            root=mounts.pop() if len(mounts) == 1 else None,
            leaves=frozenset(leaves),
            subparts={leaf: ancestry.most_specific(ts) for leaf, ts in sub_types.items() if leaf in leaves},
            confidence=float(str(confidence)) if confidence is not None else None,
        ))
    return out


def _urdf_names(graph: rdflib.Graph, node, prop: URIRef) -> set[str]:
    return {str(n) for obj in graph.objects(node, prop) for n in graph.objects(obj, CORE.urdfName)}


def read_body(graph: rdflib.Graph, ancestry: ClassAncestry | None = None) -> list[PredictedBodyPart]:
    """The predicted body parts of ``graph`` (spec: "Whole body"): individuals typed under
    ``BodyPart`` reached from the ``Robot`` by one or more ``hasComponent`` steps, so a wheel
    under the mobile base counts as well as the base. Joints are not yet restricted to the
    scored ones; :func:`urdfkb.pipeline.scoring.body_scoring.score_body` does that. ``ancestry`` as in
    read_prediction.
    """
    ancestry = ancestry or ClassAncestry(graph)
    body = CORE[vocabulary().body_part]
    reached = set()
    for robot in graph.subjects(RDF.type, CORE.Robot):
        reached |= _reach(graph, robot, CORE.hasComponent)
    out = []
    for node in sorted(reached):
        types = [t for t in graph.objects(node, RDF.type) if isinstance(t, URIRef) and ancestry.is_under(t, body)]
        if not types:
            continue
        sides = {str(s) for s in graph.objects(node, CORE.side)}
        mounts = _urdf_names(graph, node, CORE.isMountedOn)
        out.append(PredictedBodyPart(
            node=str(node),
            cls=ancestry.most_specific(types),
            side=sides.pop() if len(sides) == 1 else None,
            root=mounts.pop() if len(mounts) == 1 else None,
            joints=frozenset(_urdf_names(graph, node, CORE.hasJoint)),
            links=frozenset(_urdf_names(graph, node, CORE.hasLink)),
        ))
    return out
