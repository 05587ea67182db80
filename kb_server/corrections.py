"""Reviewers' corrections of a populated robot: what they say, how they are applied, how they are stored.

A component correction names its component by the component's member links (stable across
re-populates, unlike the model's component names) and says one of:

- `reclassify` to `cls` (a class of the same kind whose parts the ontology allows),
- `remount` on `mount` (a link above all the component's links),
- `reject` (not a component), `confirm` (right as it is),
- `add` a component of `cls` made of `links`, mounted on `mount`.

A body correction names a body part as the reviewer saw it and is stored with the part's joints
(its links where it has none), which find it again; it says one of `reclassify` to a BodyPart
class, `side` (left, right, none), `merge` with another part it touches, `split` at one of its
joints, `reject` (kb_server.body_corrections does each). Components follow their body part.

The store keeps a correction only if the robot it makes satisfies the SHACL shapes (Store.add_correction).

Corrections live in their own named graph per robot (`corrections_iri(robot)`), as PROV-O
activities (who: `prov:wasAssociatedWith` an agent, when: `prov:endedAtTime`), so they survive
re-populating the robot: `apply` lays them over the model's abstraction in time order and says
which applied and which no longer fit the URDF. A correction wins over the model.
"""
from __future__ import annotations

import uuid
from dataclasses import dataclass, replace
from datetime import datetime, timezone
from typing import Any

import rdflib
from rdflib.namespace import PROV, RDF, RDFS, XSD

from urdfkb.kb_server import body_corrections as body
from urdfkb.kb_server.text import check_text, cut, listed
from urdfkb.pipeline.abstraction.components import Abstraction, BodyPart, Component, SubComponent
from urdfkb.pipeline.errors import CorrectionError
from urdfkb.pipeline.knowledge.namespaces import CORE, CORE_IRI, REVIEW, body_part_local, component_iri, corrections_iri, escape
from urdfkb.pipeline.knowledge.ontology import vocabulary
from urdfkb.pipeline.reading.tree import KinematicTree, fork_of
from urdfkb.settings import MAX_LINKS, MAX_REVIEWER

ACTIONS = ("reclassify", "remount", "reject", "confirm", "add")
BODY_ACTIONS = ("reclassify", "side", "merge", "split", "reject")


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
            raise CorrectionError(f"action must be one of {', '.join(ACTIONS)}, not {cut(repr(action), 100)}")
        links = data.get("links")
        if not isinstance(links, list) or not links or not all(isinstance(x, str) and x for x in links):
            raise CorrectionError("links must be a non-empty list of URDF link names")
        if len(links) > MAX_LINKS:
            raise CorrectionError(f"links must name at most {MAX_LINKS:,} links (a robot has no more), not {len(links):,}")
        klass, mount = _strings(data, "class", "mount")
        if action in ("reclassify", "add") and not klass:
            raise CorrectionError(f"{action} needs a class")
        if action == "remount" and not mount:
            raise CorrectionError("remount needs a mount link")
        ident, who, time = _stamp(reviewer)
        return cls(ident, action, tuple(sorted(set(links))), who, time,
                   klass if action in ("reclassify", "add") else None,
                   mount if action in ("remount", "add") else None)

    def describe(self) -> str:
        what = {"reclassify": f"class -> {self.cls}", "remount": f"mount -> {self.mount}", "reject": "rejected",
                "confirm": "confirmed", "add": f"added {self.cls} on {self.mount or 'its parent link'}"}[self.action]
        return f"{', '.join(self.links)}: {what}"

    def to_dict(self) -> dict:
        return {"id": self.id, "action": self.action, "links": list(self.links), "class": self.cls,
                "mount": self.mount, "reviewer": self.reviewer, "time": self.time, "summary": self.describe()}


@dataclass(frozen=True)
class BodyCorrection:
    """One reviewer's decision about one body part (see the module docstring); `joints` and `links` (for a
    part without joints) name the part, `other_joints`, `other_links` the one a merge takes in."""

    id: str
    action: str
    part: str
    reviewer: str
    time: str
    joints: tuple[str, ...] = ()
    links: tuple[str, ...] = ()
    cls: str | None = None
    side: str | None = None
    at: str | None = None
    other: str | None = None
    other_joints: tuple[str, ...] = ()
    other_links: tuple[str, ...] = ()

    @classmethod
    def new(cls, data: dict, reviewer: str | None) -> "BodyCorrection":
        """From request JSON ({part, action, class?, side?, with?, at?}), the part named as the robot has it
        now (`resolve` finds its joints); CorrectionError naming the field if malformed."""
        action = data.get("action")
        if action not in BODY_ACTIONS:
            raise CorrectionError(f"a body part's action must be one of {', '.join(BODY_ACTIONS)}, "
                                  f"not {cut(repr(action), 100)}")
        part, klass, side, at, other = _strings(data, "part", "class", "side", "at", "with")
        if not part:
            raise CorrectionError("part must name the body part (as the robot page and the body_parts query name it)")
        needs = {"reclassify": ("class", klass), "side": ("side", side), "merge": ("with", other), "split": ("at", at)}
        if action in needs and not needs[action][1]:
            raise CorrectionError(f"{action} needs `{needs[action][0]}`")
        if klass and action in ("reclassify", "split"):
            body.check_class(klass)
        if action == "side":
            body.check_side(side)
        ident, who, time = _stamp(reviewer)
        return cls(ident, action, part, who, time, cls=klass if action in ("reclassify", "split") else None,
                   side=side if action == "side" else None, at=at if action == "split" else None,
                   other=other if action == "merge" else None)

    def describe(self) -> str:
        what = {"reclassify": f"class -> {self.cls}", "side": f"side -> {self.side}", "merge": f"merged with {self.other}",
                "split": f"split at {self.at}" + (f" ({self.cls} below)" if self.cls else ""),
                "reject": "rejected"}[self.action]
        return f"body part {self.part}: {what}"

    def to_dict(self) -> dict:
        return {"id": self.id, "action": self.action, "part": self.part, "joints": list(self.joints),
                "links": list(self.links), "class": self.cls, "side": self.side, "at": self.at, "with": self.other,
                "reviewer": self.reviewer, "time": self.time, "summary": self.describe()}


AnyCorrection = Correction | BodyCorrection


def new(data: dict) -> AnyCorrection:
    """A correction from request JSON: of a body part when it names a `part`, else of a component."""
    return (BodyCorrection if "part" in data else Correction).new(data, data.get("reviewer"))


def _strings(data: dict, *fields: str) -> list:
    """The request's `fields` (None where empty); CorrectionError naming one that is not a string."""
    values = [data.get(field) or None for field in fields]
    for field, value in zip(fields, values):
        if value is not None and not isinstance(value, str):
            raise CorrectionError(f"{field} must be a string, not {type(value).__name__}")
    return values


def _stamp(reviewer: object) -> tuple[str, str, str]:
    """A new correction's id, its reviewer's name (whitespace runs become one space, other control characters
    are refused) and its time."""
    (name,) = _strings({"reviewer": reviewer}, "reviewer")
    try:
        who = check_text("reviewer", " ".join((name or "").split())[:MAX_REVIEWER]) or "anonymous reviewer"
    except ValueError as e:
        raise CorrectionError(str(e)) from None
    return uuid.uuid4().hex[:12], who, datetime.now(timezone.utc).isoformat(timespec="microseconds")


@dataclass
class Report:
    """What applying corrections did: (correction, component or body part name) applied, (correction, reason) stale."""

    applied: list[tuple[AnyCorrection, str]]
    stale: list[tuple[AnyCorrection, str]]

    def to_dict(self) -> dict:
        return {"applied": [{**c.to_dict(), ("part" if isinstance(c, BodyCorrection) else "component"): name}
                            for c, name in self.applied],
                "stale": [{**c.to_dict(), "reason": why} for c, why in self.stale]}


def apply(tree: KinematicTree, model: Abstraction, corrections: list[AnyCorrection]) -> tuple[Abstraction, Report]:
    """The model's abstraction with every correction that fits laid over it, in time order."""
    comps, parts = list(model.components), list(model.body)
    report = Report([], [])
    for corr in sorted(corrections, key=lambda c: (c.time, c.id)):
        try:
            comps, parts, name = _apply_one(tree, comps, parts, corr)
        except CorrectionError as e:
            report.stale.append((corr, str(e)))
        else:
            report.applied.append((corr, name))
    return Abstraction(tuple(comps), dict(model.provenance), tuple(parts)), report


def resolve(current: Abstraction, corr: AnyCorrection) -> AnyCorrection:
    """`corr` naming the body parts it is about by their joints (links where they have none), found by name in
    the robot as it now is; CorrectionError if it names a part the robot does not have."""
    if not isinstance(corr, BodyCorrection):
        return corr
    parts = list(current.body)
    part = body.named(parts, corr.part)
    other = body.named(parts, corr.other) if corr.other else None
    return replace(corr, joints=tuple(sorted(part.joints)), links=() if part.joints else tuple(sorted(part.links)),
                   other_joints=tuple(sorted(other.joints)) if other else (),
                   other_links=tuple(sorted(other.links)) if other and not other.joints else ())


def check(tree: KinematicTree, current: Abstraction, corr: AnyCorrection) -> None:
    """CorrectionError unless `corr` applies to the robot as it now is."""
    _apply_one(tree, list(current.components), list(current.body), corr)


def kind_of(cls: str) -> str | None:
    return vocabulary().kind_of(cls)


def allowed_classes(comp: Component) -> tuple[str, ...]:
    """Classes a reviewer may give `comp`: its kind's classes that allow all its parts' classes."""
    vocab = vocabulary()
    parts = {s.cls for s in comp.subcomponents}
    root = vocab.kinds[comp.kind].cls
    return tuple(c for c in (root, *vocab.subclasses_below(root))
                 if not parts & vocab.excluded_parts(c))


def mount_options(tree: KinematicTree, links: tuple[str, ...]) -> tuple[str, ...]:
    """Links above every one of `links` (nearest first): where such a group may be mounted."""
    own = set(links)
    return tuple(a for a in tree.chain_to_root(fork_of(tree, list(links))) if a not in own)


def _find(comps: list[Component], links: tuple[str, ...]) -> int:
    wanted = set(links)
    for i, c in enumerate(comps):
        if set(c.links) == wanted:
            return i
    for i, c in enumerate(comps):
        if wanted <= set(c.links):
            return i
    raise CorrectionError(f"no component with link{'s' if len(links) > 1 else ''} {listed(links)} any more")


State = tuple[list[Component], list[BodyPart], str]  # components, body parts, the name of what a correction changed


def _apply_one(tree: KinematicTree, comps: list[Component], parts: list[BodyPart], corr: AnyCorrection) -> State:
    if isinstance(corr, BodyCorrection):
        return _apply_body(tree, comps, parts, corr)
    known = set(tree.links)
    missing = [link for link in corr.links if link not in known]
    if missing:
        raise CorrectionError(f"link {listed(missing)} {'is' if len(missing) == 1 else 'are'} not in the URDF any more")
    if corr.action == "add":
        return _add(tree, comps, parts, corr)
    i = _find(comps, corr.links)
    comp = comps[i]
    if corr.action == "reject":
        return comps[:i] + comps[i + 1:], parts, comp.name
    if corr.action == "confirm":
        return comps, parts, comp.name
    if corr.action == "reclassify":
        if corr.cls not in allowed_classes(comp):
            raise CorrectionError(f"{cut(corr.cls or '', 100)} is not a class the ontology allows for {comp.name} "
                                  f"(allowed: {', '.join(allowed_classes(comp))})")
        new = replace(comp, cls=corr.cls, confidence=1.0, fingers=())  # the chains argued for the old class
    else:
        if corr.mount not in mount_options(tree, comp.links):
            raise CorrectionError(f"{cut(corr.mount or '', 100)} is not above every link of {comp.name}")
        new = body.relocate(tree, replace(comp, root=corr.mount), parts)
    return comps[:i] + [new] + comps[i + 1:], parts, comp.name


def _apply_body(tree: KinematicTree, comps: list[Component], parts: list[BodyPart], corr: BodyCorrection) -> State:
    known = {e.joint for e in tree.edges}
    missing = [j for j in (*corr.joints, *corr.other_joints, *([corr.at] if corr.at else [])) if j not in known]
    if missing:
        raise CorrectionError(f"joint {listed(missing)} {'is' if len(missing) == 1 else 'are'} not in the URDF any more")
    i = body.find(parts, corr.joints, corr.links)
    name = parts[i].name
    if corr.action == "reclassify":
        parts, comps = body.reclassify(parts, comps, i, corr.cls or "")
    elif corr.action == "side":
        parts, comps = body.set_side(parts, comps, i, corr.side or "")
    elif corr.action == "merge":
        j = body.find(parts, corr.other_joints, corr.other_links)
        names = (name, parts[j].name)
        parts, comps = body.merge(tree, parts, comps, i, j)
        name = next(p.name for p in parts if p.name in names)  # the upper one's
    elif corr.action == "split":
        parts, comps = body.split(tree, parts, comps, i, corr.at or "", corr.cls)
    else:
        parts, comps = body.reject(tree, parts, comps, i)
    return comps, parts, name


def _add(tree: KinematicTree, comps: list[Component], parts: list[BodyPart], corr: Correction) -> State:
    cls = corr.cls or ""
    kind = kind_of(cls)
    if kind is None:
        raise CorrectionError(f"{cut(cls, 100)} is not a sensor or end-effector class of the ontology")
    options = mount_options(tree, corr.links)
    if not options:
        raise CorrectionError("the links have no common link above them to mount on")
    mount = corr.mount or options[0]
    if mount not in options:
        raise CorrectionError(f"{cut(mount, 100)} is not above every selected link")
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
    parts = [replace(p, links=tuple(link for link in p.links if link not in taken)) for p in parts]  # a device's, now
    added = body.relocate(tree, Component(name, kind, cls, 1.0, mount, _new_parts(tree, corr)), parts)
    return kept + [added], parts, name


def _new_parts(tree: KinematicTree, corr: Correction) -> tuple[SubComponent, ...]:
    """An added component's sub-parts: each chain's last link is the part the shapes require of its class (a
    camera's optical frame), as the pipeline types it; the other links, and all of a class requiring none, Subpart."""
    vocab = vocabulary()
    required = vocab.required_part(corr.cls or "")
    above = _ancestors(tree, corr.links)
    ends = {link for link in corr.links if link not in above}
    return tuple(SubComponent(link, required if required and link in ends else vocab.subpart, 1.0) for link in corr.links)


def _ancestors(tree: KinematicTree, links: tuple[str, ...]) -> set[str]:
    """The links above any of `links` (each walked up only until a link already seen): linear in the tree."""
    above: set[str] = set()
    for link in links:
        parent = tree.parent(link)
        while parent is not None and parent not in above:
            above.add(parent)
            parent = tree.parent(parent)
    return above


# --- the named graph ---------------------------------------------------------------------------

# How each record's own fields are written: (predicate, "many" literals | one core "class" | "one" literal).
_FIELDS = {
    Correction: {"links": (REVIEW.link, "many"), "cls": (REVIEW.newClass, "class"), "mount": (REVIEW.newMount, "one")},
    BodyCorrection: {"part": (REVIEW.part, "one"), "joints": (REVIEW.joint, "many"), "links": (REVIEW.link, "many"),
                     "cls": (REVIEW.newClass, "class"), "side": (REVIEW.newSide, "one"), "at": (REVIEW.splitAt, "one"),
                     "other": (REVIEW.mergeWith, "one"), "other_joints": (REVIEW.mergeJoint, "many"),
                     "other_links": (REVIEW.mergeLink, "many")},
}
_TYPES = {Correction: REVIEW.Correction, BodyCorrection: REVIEW.BodyPartCorrection}


def to_graph(robot: str, corrections: list[AnyCorrection]) -> rdflib.Graph:
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
        g.add((node, RDF.type, _TYPES[type(c)]))
        g.add((node, RDFS.label, rdflib.Literal(c.describe())))
        g.add((node, REVIEW.action, rdflib.Literal(c.action)))
        for field, (predicate, how) in _FIELDS[type(c)].items():
            value = getattr(c, field)
            for v in value if how == "many" else [value] if value else []:
                g.add((node, predicate, CORE[v] if how == "class" else rdflib.Literal(v)))
        g.add((node, PROV.endedAtTime, rdflib.Literal(c.time, datatype=XSD.dateTime)))
        g.add((node, PROV.wasAssociatedWith, agent))
        g.add((agent, RDF.type, PROV.Agent))
        g.add((agent, RDFS.label, rdflib.Literal(c.reviewer)))
    return g


def from_graph(graph: rdflib.Graph) -> list[AnyCorrection]:
    """The corrections in a graph written by `to_graph`, oldest first."""
    out: list[AnyCorrection] = []
    for record, rdf_type in _TYPES.items():
        for node in graph.subjects(RDF.type, rdf_type):
            fields: dict[str, Any] = {"id": str(node).rsplit("correction_", 1)[1],
                                         "action": str(graph.value(node, REVIEW.action)),
                                         "reviewer": str(graph.value(graph.value(node, PROV.wasAssociatedWith), RDFS.label)),
                                         "time": str(graph.value(node, PROV.endedAtTime))}
            for field, (predicate, how) in _FIELDS[record].items():
                values = sorted(str(v)[len(CORE_IRI):] if how == "class" else str(v) for v in graph.objects(node, predicate))
                fields[field] = tuple(values) if how == "many" else values[0] if values else None
            out.append(record(**fields))
    return sorted(out, key=lambda c: (c.time, c.id))


def influences(robot_ns: str, robot: str, report: Report) -> list[tuple[str, str]]:
    """(component or body part IRI, correction IRI) pairs for `prov:wasInfluencedBy` in the robot graph."""
    base = corrections_iri(robot)
    return [(robot_ns + body_part_local(name) if isinstance(c, BodyCorrection) else component_iri(robot_ns, name),
             f"{base}correction_{c.id}")
            for c, name in report.applied if c.action != "reject"]
