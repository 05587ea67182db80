"""Reviewers' corrections of a populated robot: what they say, how they are applied, how they are stored.

A correction names its component by the component's member links (stable across re-populates,
unlike the model's component names) and says one of:

- `reclassify` to `cls` (a class of the same kind whose parts the ontology allows),
- `remount` on `mount` (a link above all the component's links),
- `reject` (not a component), `confirm` (right as it is),
- `add` a component of `cls` made of `links`, mounted on `mount`.

Corrections live in their own named graph per robot (`corrections_iri(robot)`), as PROV-O
activities (who: `prov:wasAssociatedWith` an agent, when: `prov:endedAtTime`), so they survive
re-populating the robot: `apply` lays them over the model's abstraction in time order and says
which applied and which no longer fit the URDF. A correction wins over the model.
"""
from __future__ import annotations

import uuid
from dataclasses import dataclass, replace
from datetime import datetime, timezone

import rdflib
from rdflib.namespace import PROV, RDF, RDFS, XSD

from urdfkb.kb_server.text import check_text
from urdfkb.pipeline.components import Abstraction, Component, SubComponent
from urdfkb.pipeline.errors import UrdfkbError
from urdfkb.pipeline.namespaces import CORE, CORE_IRI, REVIEW, component_iri, corrections_iri, escape
from urdfkb.pipeline.ontology import vocabulary
from urdfkb.pipeline.tree import KinematicTree

ACTIONS = ("reclassify", "remount", "reject", "confirm", "add")
MAX_REVIEWER = 100


class CorrectionError(UrdfkbError, ValueError):
    """A correction that does not fit the robot (or is malformed); the message says why."""


@dataclass(frozen=True)
class Correction:
    """One reviewer's decision about one component (see the module docstring)."""

    id: str
    action: str
    links: tuple[str, ...]
    reviewer: str
    time: str
    cls: str | None = None
    mount: str | None = None

    @classmethod
    def new(cls, data: dict, reviewer: str | None) -> "Correction":
        """From request JSON ({action, links, class?, mount?}); CorrectionError naming the field if malformed.

        The reviewer's whitespace runs become one space; other control characters are refused."""
        action = data.get("action")
        if action not in ACTIONS:
            raise CorrectionError(f"action must be one of {', '.join(ACTIONS)}, not {action!r}")
        links = data.get("links")
        if not isinstance(links, list) or not links or not all(isinstance(x, str) and x for x in links):
            raise CorrectionError("links must be a non-empty list of URDF link names")
        klass, mount = data.get("class") or None, data.get("mount") or None
        for field, value in (("class", klass), ("mount", mount), ("reviewer", reviewer)):
            if value is not None and not isinstance(value, str):
                raise CorrectionError(f"{field} must be a string, not {type(value).__name__}")
        if action in ("reclassify", "add") and not klass:
            raise CorrectionError(f"{action} needs a class")
        if action == "remount" and not mount:
            raise CorrectionError("remount needs a mount link")
        try:
            who = check_text("reviewer", " ".join((reviewer or "").split())[:MAX_REVIEWER]) or "anonymous reviewer"
        except ValueError as e:
            raise CorrectionError(str(e)) from None
        return cls(uuid.uuid4().hex[:12], action, tuple(sorted(set(links))), who,
                   datetime.now(timezone.utc).isoformat(timespec="microseconds"),
                   klass if action in ("reclassify", "add") else None,
                   mount if action in ("remount", "add") else None)

    def describe(self) -> str:
        what = {"reclassify": f"class -> {self.cls}", "remount": f"mount -> {self.mount}", "reject": "rejected",
                "confirm": "confirmed", "add": f"added {self.cls} on {self.mount or 'its parent link'}"}[self.action]
        return f"{', '.join(self.links)}: {what}"

    def to_dict(self) -> dict:
        return {"id": self.id, "action": self.action, "links": list(self.links), "class": self.cls,
                "mount": self.mount, "reviewer": self.reviewer, "time": self.time, "summary": self.describe()}


@dataclass
class Report:
    """What applying corrections did: (correction, component name) applied, (correction, reason) stale."""

    applied: list[tuple[Correction, str]]
    stale: list[tuple[Correction, str]]

    def to_dict(self) -> dict:
        return {"applied": [{**c.to_dict(), "component": name} for c, name in self.applied],
                "stale": [{**c.to_dict(), "reason": why} for c, why in self.stale]}


def apply(tree: KinematicTree, model: Abstraction, corrections: list[Correction]) -> tuple[Abstraction, Report]:
    """The model's abstraction with every correction that fits laid over it, in time order."""
    comps = list(model.components)
    report = Report([], [])
    for corr in sorted(corrections, key=lambda c: (c.time, c.id)):
        try:
            comps, name = _apply_one(tree, comps, corr)
        except CorrectionError as e:
            report.stale.append((corr, str(e)))
        else:
            report.applied.append((corr, name))
    return Abstraction(tuple(comps), dict(model.provenance), model.body), report


def check(tree: KinematicTree, current: Abstraction, corr: Correction) -> None:
    """CorrectionError unless `corr` applies to the robot as it now is."""
    _apply_one(tree, list(current.components), corr)


def kind_of(cls: str) -> str | None:
    return vocabulary().kind_of(cls)


def allowed_classes(comp: Component) -> tuple[str, ...]:
    """Classes a reviewer may give `comp`: its kind's classes that allow all its parts' classes."""
    tax = vocabulary()
    parts = {s.cls for s in comp.subcomponents}
    root = tax.kinds[comp.kind].cls
    return tuple(c for c in (root, *tax.subclasses_below(root))
                 if not parts & tax.excluded_parts(c))


def mount_options(tree: KinematicTree, links: tuple[str, ...]) -> tuple[str, ...]:
    """Links above every one of `links` (nearest first): where such a group may be mounted."""
    chains = [tree.chain_to_root(link) for link in links]
    common = [a for a in chains[0] if all(a in ch for ch in chains[1:])]
    return tuple(a for a in common if a not in links)


def _find(comps: list[Component], links: tuple[str, ...]) -> int:
    wanted = set(links)
    for i, c in enumerate(comps):
        if set(c.links) == wanted:
            return i
    for i, c in enumerate(comps):
        if wanted <= set(c.links):
            return i
    raise CorrectionError(f"no component with link{'s' if len(links) > 1 else ''} {', '.join(links)} any more")


def _apply_one(tree: KinematicTree, comps: list[Component], corr: Correction) -> tuple[list[Component], str]:
    missing = [link for link in corr.links if link not in tree.links]
    if missing:
        raise CorrectionError(f"link {', '.join(missing)} is not in the URDF any more")
    if corr.action == "add":
        return _add(tree, comps, corr)
    i = _find(comps, corr.links)
    comp = comps[i]
    if corr.action == "reject":
        return comps[:i] + comps[i + 1:], comp.name
    if corr.action == "confirm":
        return comps, comp.name
    if corr.action == "reclassify":
        if corr.cls not in allowed_classes(comp):
            raise CorrectionError(f"{corr.cls} is not a class the ontology allows for {comp.name} "
                                  f"(allowed: {', '.join(allowed_classes(comp))})")
        new = replace(comp, cls=corr.cls, confidence=1.0, fingers=())  # the chains argued for the old class
    else:
        if corr.mount not in mount_options(tree, comp.links):
            raise CorrectionError(f"{corr.mount} is not above every link of {comp.name}")
        new = replace(comp, root=corr.mount)
    return comps[:i] + [new] + comps[i + 1:], comp.name


def _add(tree: KinematicTree, comps: list[Component], corr: Correction) -> tuple[list[Component], str]:
    kind = kind_of(corr.cls or "")
    if kind is None:
        raise CorrectionError(f"{corr.cls} is not a sensor or end-effector class of the ontology")
    options = mount_options(tree, corr.links)
    if not options:
        raise CorrectionError("the links have no common link above them to mount on")
    mount = corr.mount or options[0]
    if mount not in options:
        raise CorrectionError(f"{mount} is not above every selected link")
    taken = set(corr.links)
    kept = []
    for c in comps:  # the reviewer's component takes its links from whatever the model put them in
        subs = tuple(s for s in c.subcomponents if s.link not in taken)
        if subs:
            kept.append(replace(c, subcomponents=subs, fingers=() if len(subs) < len(c.subcomponents) else c.fingers))
    names = {c.name for c in kept}
    name = f"reviewed_{corr.links[0]}"
    while name in names:
        name += "_"
    subs = tuple(SubComponent(link, vocabulary().subpart, 1.0) for link in corr.links)
    return kept + [Component(name, kind, corr.cls, 1.0, mount, subs)], name


# --- the named graph ---------------------------------------------------------------------------

def to_graph(robot: str, corrections: list[Correction]) -> rdflib.Graph:
    """The corrections as PROV-O activities, one agent per reviewer name."""
    g = rdflib.Graph()
    g.bind("prov", PROV)
    g.bind("review", REVIEW)
    g.bind("core", CORE)
    base = corrections_iri(robot)
    for c in corrections:
        node = rdflib.URIRef(base + "correction_" + c.id)
        agent = rdflib.URIRef(base + "reviewer_" + escape(c.reviewer))
        g.add((node, RDF.type, PROV.Activity))
        g.add((node, RDF.type, REVIEW.Correction))
        g.add((node, RDFS.label, rdflib.Literal(c.describe())))
        g.add((node, REVIEW.action, rdflib.Literal(c.action)))
        for link in c.links:
            g.add((node, REVIEW.link, rdflib.Literal(link)))
        if c.cls:
            g.add((node, REVIEW.newClass, CORE[c.cls]))
        if c.mount:
            g.add((node, REVIEW.newMount, rdflib.Literal(c.mount)))
        g.add((node, PROV.endedAtTime, rdflib.Literal(c.time, datatype=XSD.dateTime)))
        g.add((node, PROV.wasAssociatedWith, agent))
        g.add((agent, RDF.type, PROV.Agent))
        g.add((agent, RDFS.label, rdflib.Literal(c.reviewer)))
    return g


def from_graph(graph: rdflib.Graph) -> list[Correction]:
    """The corrections in a graph written by `to_graph`, oldest first."""
    out = []
    for node in graph.subjects(RDF.type, REVIEW.Correction):
        cls = graph.value(node, REVIEW.newClass)
        mount = graph.value(node, REVIEW.newMount)
        agent = graph.value(node, PROV.wasAssociatedWith)
        out.append(Correction(
            str(node).rsplit("correction_", 1)[1], str(graph.value(node, REVIEW.action)),
            tuple(sorted(str(x) for x in graph.objects(node, REVIEW.link))),
            str(graph.value(agent, RDFS.label)), str(graph.value(node, PROV.endedAtTime)),
            str(cls)[len(CORE_IRI):] if cls else None, str(mount) if mount else None))
    return sorted(out, key=lambda c: (c.time, c.id))


def influences(robot_ns: str, robot: str, report: Report) -> list[tuple[str, str]]:
    """(component IRI, correction IRI) pairs for `prov:wasInfluencedBy` in the robot graph."""
    base = corrections_iri(robot)
    return [(component_iri(robot_ns, name), f"{base}correction_{c.id}")
            for c, name in report.applied if c.action != "reject"]
