"""Abstraction accuracy against the ground truth, as defined in ../shared/spec/evaluation.md.

A populated graph is read by the core namespace and the local names of ../shared/spec/ontology.md only;
class ancestry comes from the graph's own ``rdfs:subClassOf`` triples, and which class roots each
kind and its sub-parts from the Vocabulary (``core:componentKind`` and its ``hasComponent`` branch).

Conventions beyond the spec (each also stated where it applies):

* Matching is one-to-one on equal leaf sets. Over both kinds the kind is not compared; per
  kind, predictions and truth are both filtered to that kind first, so a prediction whose
  leaves equal a truth component of the other kind is a false positive in its own kind and a
  miss in the truth's kind (over both kinds it matches, and its class earns no typed credit
  because it is not under the truth's branch).
* As the spec says: a kind with no truth component scores precision, recall and F1 of 1 when
  nothing of that kind is predicted (precision and F1 0 when something is); its root accuracy is
  undefined (None), as is the subpart accuracy of a scope whose truth lists no subparts. Means
  over robots skip undefined values. Root accuracy is 0 when truth components exist but none
  matched; subpart accuracy 0 when subparts are listed but none was matched.
* Hedging does not pay: an individual with several incomparable most specific classes has no
  class (``None``, no credit), one with several ``isMountedOn`` links has no root.

The whole body (spec: "Whole body") is scored by :func:`score` when it is given the URDF's
kinematic tree; its conventions are in :func:`score_body`.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from statistics import fmean
from typing import Iterable, Mapping

import rdflib
import yaml
from rdflib import RDF, RDFS, URIRef
from rdflib.term import Node

from urdfkb.pipeline.components import END_EFFECTOR, KINDS, SIDES
from urdfkb.pipeline.errors import UrdfkbError
from urdfkb.pipeline.namespaces import CORE
from urdfkb.pipeline.ontology import vocabulary
from urdfkb.pipeline.tree import KinematicTree
from urdfkb.settings import REVIEW_THRESHOLD

ALL = "all"
SCOPES = (ALL, *KINDS)
METRICS = (
    "leaf_precision", "leaf_recall", "leaf_f1",
    "component_precision", "component_recall", "component_f1",
    "typed_precision", "typed_recall", "typed_f1",
    "root_accuracy", "subpart_accuracy",
)
COUNTS = ("n_predicted", "n_truth", "n_matched", "n_subparts", "n_wrong", "n_queued", "n_wrong_queued")
BODY = "body"
BODY_METRICS = (
    "part_precision", "part_recall", "part_f1",
    "typed_precision", "typed_recall", "typed_f1",
    "side_accuracy", "root_accuracy", "joint_accuracy",
)
BODY_COUNTS = ("n_predicted", "n_truth", "n_matched", "n_joints")


@dataclass(frozen=True)
class TruthComponent:
    id: str
    kind: str
    classes: frozenset[str]
    roots: frozenset[str]
    leaves: frozenset[str]
    subparts: Mapping[str, frozenset[str]] = field(default_factory=dict, hash=False)


@dataclass(frozen=True)
class Alternative:
    """Another accepted partition: truth components ``replace`` may be read as ``with_``."""

    replace: tuple[str, ...]
    with_: tuple[TruthComponent, ...]


@dataclass(frozen=True)
class TruthBodyPart:
    """One part of the truth's ``body:`` section; ``links`` keeps file order (the first one
    identifies a part without joints)."""

    id: str
    classes: frozenset[str]
    roots: frozenset[str]
    joints: frozenset[str]
    links: tuple[str, ...] = ()
    side: str | None = None


@dataclass(frozen=True)
class TruthBody:
    ignore_joints: frozenset[str]
    parts: tuple[TruthBodyPart, ...]


@dataclass(frozen=True)
class Truth:
    robot: str
    urdf: str
    ignore: frozenset[str]
    components: tuple[TruthComponent, ...]
    alternatives: tuple[Alternative, ...] = ()
    body: TruthBody | None = None     # None: the file has no body section (body metrics undefined)


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


def _truth_component(d: dict) -> TruthComponent:
    if d["kind"] not in KINDS:
        raise ValueError(f"truth component {d['id']}: unknown kind {d['kind']!r}")
    leaves = frozenset(d["leaves"])
    subparts = {k: frozenset(v) for k, v in (d.get("subparts") or {}).items()}
    if not set(subparts) <= leaves:
        raise ValueError(f"truth component {d['id']}: subparts not among its leaves")
    return TruthComponent(str(d["id"]), d["kind"], frozenset(d["classes"]), frozenset(d["roots"]),
                          leaves, subparts)


def _truth_body(data: dict, path) -> TruthBody:
    ignore = frozenset(data.get("ignore_joints") or ())
    parts: list[TruthBodyPart] = []
    owner: dict[str, str] = {}  # joint → the part listing it
    for d in data.get("parts") or []:
        where = f"{path}: body part {d.get('id')!r}"
        part = TruthBodyPart(str(d["id"]), frozenset(d["classes"]), frozenset(d.get("roots") or ()),
                             frozenset(d.get("joints") or ()), tuple(d.get("links") or ()), d.get("side"))
        if not part.classes:
            raise ValueError(f"{where}: no accepted class")
        if part.side not in (None, *SIDES):
            raise ValueError(f"{where}: side {part.side!r} is not one of {', '.join(SIDES)}")
        if not part.joints and not part.links:
            raise ValueError(f"{where}: a part without joints needs links (its first one identifies it)")
        if part.joints & ignore:
            raise ValueError(f"{where}: lists ignored joints {sorted(part.joints & ignore)}")
        for joint in part.joints:
            if owner.setdefault(joint, part.id) != part.id:
                raise ValueError(f"{where}: joint {joint} is also in part {owner[joint]!r}")
        parts.append(part)
    ids = [p.id for p in parts]
    if len(set(ids)) != len(ids):
        raise ValueError(f"{path}: duplicate body part ids")
    return TruthBody(ignore, tuple(parts))


def load_truth(path: str | Path) -> Truth:
    """Parse and sanity-check a truth YAML file (format: ../shared/spec/evaluation.md), its ``body:``
    section included where present."""
    data = yaml.safe_load(Path(path).read_text())
    comps = tuple(_truth_component(c) for c in data["components"])
    ids = [c.id for c in comps]
    if len(set(ids)) != len(ids):
        raise ValueError(f"{path}: duplicate component ids")
    alts: list[Alternative] = []
    replaced: set[str] = set()
    for a in data.get("alternatives") or []:
        rep = tuple(a["replace"])
        if not set(rep) <= set(ids) or replaced & set(rep):
            raise ValueError(f"{path}: alternative replaces unknown or already replaced ids {rep}")
        replaced |= set(rep)
        alts.append(Alternative(rep, tuple(_truth_component(c) for c in a["with"])))
    body = _truth_body(data["body"] or {}, path) if "body" in data else None
    return Truth(data["robot"], data["urdf"], frozenset(data.get("ignore") or ()), comps, tuple(alts), body)


# ---- reading a prediction -------------------------------------------------------------------

class _Taxonomy:
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


def _kind_roots() -> dict[str, str]:
    """Kind → its class under Component."""
    return {k: kind.cls for k, kind in vocabulary().kinds.items()}


def _read(graph: rdflib.Graph, tax: _Taxonomy, urdf_leaves: set[str]) -> list[PredictedComponent]:
    roots = _kind_roots()

    def names(node) -> set[str]:
        return {str(n) for link in graph.objects(node, CORE.hasLink) for n in graph.objects(link, CORE.urdfName)}

    out = []
    robots = set(graph.subjects(RDF.type, CORE.Robot))
    tops = {c for r in robots for c in graph.objects(r, CORE.hasComponent)}
    for comp in sorted(tops):  # type: ignore[type-var]  # rdflib types objects as Node; these are Identifiers (str)
        types = set(graph.objects(comp, RDF.type))
        kinds = {k for k, root in roots.items() if any(tax.is_under(t, CORE[root]) for t in types)}
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
            cls=tax.most_specific(t for t in types if any(tax.is_under(t, CORE[r]) for r in roots.values())),
            root=mounts.pop() if len(mounts) == 1 else None,
            leaves=frozenset(leaves),
            subparts={leaf: tax.most_specific(ts) for leaf, ts in sub_types.items() if leaf in leaves},
            confidence=float(str(confidence)) if confidence is not None else None,
        ))
    return out


def read_prediction(graph: rdflib.Graph, urdf_leaves: set[str]) -> list[PredictedComponent]:
    """The predicted components of ``graph`` (spec: "Reading a prediction").

    Leaves are restricted to ``urdf_leaves``; pass the URDF's leaves minus the truth's
    ``ignore``. A component typed under both Sensor and EndEffector has kind None: it counts
    over both kinds but in neither per-kind scope. Components left with no leaves are kept
    here and dropped by :func:`score`.
    """
    return _read(graph, _Taxonomy(graph), set(urdf_leaves))


def _urdf_names(graph: rdflib.Graph, node, prop: URIRef) -> set[str]:
    return {str(n) for obj in graph.objects(node, prop) for n in graph.objects(obj, CORE.urdfName)}


def _read_body(graph: rdflib.Graph, tax: _Taxonomy) -> list[PredictedBodyPart]:
    body = CORE[vocabulary().body_part]
    reached = set()
    for robot in graph.subjects(RDF.type, CORE.Robot):
        reached |= _reach(graph, robot, CORE.hasComponent)
    out = []
    for node in sorted(reached):
        types = [t for t in graph.objects(node, RDF.type) if isinstance(t, URIRef) and tax.is_under(t, body)]
        if not types:
            continue
        sides = {str(s) for s in graph.objects(node, CORE.side)}
        mounts = _urdf_names(graph, node, CORE.isMountedOn)
        out.append(PredictedBodyPart(
            node=str(node),
            cls=tax.most_specific(types),
            side=sides.pop() if len(sides) == 1 else None,
            root=mounts.pop() if len(mounts) == 1 else None,
            joints=frozenset(_urdf_names(graph, node, CORE.hasJoint)),
            links=frozenset(_urdf_names(graph, node, CORE.hasLink)),
        ))
    return out


def read_body(graph: rdflib.Graph) -> list[PredictedBodyPart]:
    """The predicted body parts of ``graph`` (spec: "Whole body"): individuals typed under
    ``BodyPart`` reached from the ``Robot`` by one or more ``hasComponent`` steps, so a wheel
    under the mobile base counts as well as the base. Joints are not yet restricted to the
    scored ones; :func:`score_body` does that.
    """
    return _read_body(graph, _Taxonomy(graph))


# ---- scoring --------------------------------------------------------------------------------

def _prf(hits: float, n_pred: int, n_truth: int) -> tuple[float, float, float]:
    if not n_truth:  # nothing to find: recall holds vacuously, and any prediction is wrong
        return (0.0, 1.0, 0.0) if n_pred else (1.0, 1.0, 1.0)
    p = hits / n_pred if n_pred else 0.0
    r = hits / n_truth if n_truth else 0.0
    return p, r, (2 * p * r / (p + r) if p + r else 0.0)


def _match(preds: list[PredictedComponent], truths: list[TruthComponent], tax: _Taxonomy):
    """One-to-one pairs with equal leaf sets; among duplicates the best-typed prediction wins."""
    free = list(preds)
    pairs = []
    for t in truths:
        cands = [p for p in free if p.leaves == t.leaves]
        if cands:
            best = max(cands, key=lambda p: tax.credit(p.cls, t.classes, _kind_roots().values()))
            free.remove(best)
            pairs.append((best, t))
    return pairs


def _partition(truth: Truth, preds: list[PredictedComponent], tax: _Taxonomy):
    """Truth components after choosing, per alternatives entry, the partition matching more
    predicted components (over both kinds; a tie keeps the canonical one)."""
    by_id = {c.id: c for c in truth.components}
    comps = list(truth.components)
    chosen = {}
    for alt in truth.alternatives:
        canonical = [by_id[i] for i in alt.replace]
        use_alt = len(_match(preds, list(alt.with_), tax)) > len(_match(preds, canonical, tax))
        chosen["+".join(alt.replace)] = "alternative" if use_alt else "canonical"
        if use_alt:
            comps = [c for c in comps if c.id not in alt.replace] + list(alt.with_)
    return comps, chosen


def _scope(preds: list[PredictedComponent], truths: list[TruthComponent], tax: _Taxonomy) -> dict:
    pairs = _match(preds, truths, tax)
    pred_leaves = set().union(*(p.leaves for p in preds))
    truth_leaves = set().union(*(t.leaves for t in truths))
    out: dict[str, float | None] = dict(zip(("leaf_precision", "leaf_recall", "leaf_f1"),
                   _prf(len(pred_leaves & truth_leaves), len(pred_leaves), len(truth_leaves))))
    out.update(zip(("component_precision", "component_recall", "component_f1"),
                   _prf(len(pairs), len(preds), len(truths))))
    credits = {p.node: tax.credit(p.cls, t.classes, _kind_roots().values()) for p, t in pairs}
    typed = sum(credits.values())
    out.update(zip(("typed_precision", "typed_recall", "typed_f1"), _prf(typed, len(preds), len(truths))))
    out["root_accuracy"] = (fmean(p.root in t.roots for p, t in pairs) if pairs else 0.0) if truths else None
    subpart_roots = [kind.subparts for kind in vocabulary().kinds.values()]
    sub = [tax.credit(p.subparts.get(leaf), accepted, subpart_roots)
           for p, t in pairs for leaf, accepted in t.subparts.items()]
    listed = any(t.subparts for t in truths)
    out["subpart_accuracy"] = (fmean(sub) if sub else 0.0) if listed else None
    out.update(n_predicted=len(preds), n_truth=len(truths), n_matched=len(pairs), n_subparts=len(sub))
    # The review queue: components below REVIEW_THRESHOLD; wrong: matching no truth component, or typed short of it
    right = {node for node, credit in credits.items() if credit == 1.0}
    wrong = [p for p in preds if p.node not in right]
    queued = [p for p in preds if p.confidence is not None and p.confidence < REVIEW_THRESHOLD]
    out.update(n_wrong=len(wrong), n_queued=len(queued), n_wrong_queued=len({p.node for p in queued} & {p.node for p in wrong}))
    return out


def review_queue(means: Mapping[str, object]) -> str:
    """One line on the review queue over the robots summed in `means` (mean_scores' counts): the share of wrong
    components it holds and the share of all predicted components it takes."""
    counts = means[ALL]
    assert isinstance(counts, Mapping)
    wrong, queued, caught, predicted = (counts[c] for c in ("n_wrong", "n_queued", "n_wrong_queued", "n_predicted"))
    held = f"{caught / wrong:.0%}" if wrong else "-"
    takes = f"{queued / predicted:.0%}" if predicted else "-"
    return (f"review queue (confidence < {REVIEW_THRESHOLD}): holds {held} of the {wrong} wrong components "
            f"({caught}), takes {takes} of the {predicted} predicted ({queued})")


def score(truth: Truth, graph: rdflib.Graph, urdf_leaves: set[str], tree: KinematicTree | None = None) -> dict:
    """Every metric of ../shared/spec/evaluation.md for one robot.

    Returns ``{"all"|"sensor"|"end_effector": {metric: float, count: int}, "body": {body
    metric: float, count: int}, "partitions": {replaced ids: "canonical"|"alternative"},
    "differences": [what the prediction got wrong, one line each], "failed": False}``. The body metrics (:func:`score_body`) need the URDF's ``tree`` (which
    joints move, which lead to an end-effector) and a truth with a body section; without either
    they are undefined (None) and skipped in means. Ignored leaves are removed
    from predicted and truth leaf sets. A predicted component with no leaf left is not a
    prediction: the spec identifies components by their leaves, so it can match nothing, and
    counting it would penalise labelling exactly what ``ignore`` (or a non-leaf link, such as
    a bonus sensor on an inner link) declares unscored.
    """
    tax = _Taxonomy(graph)
    scorable = set(urdf_leaves) - truth.ignore
    preds = [p for p in _read(graph, tax, scorable) if p.leaves]
    truths, chosen = _partition(truth, preds, tax)
    truths = [TruthComponent(t.id, t.kind, t.classes, t.roots, t.leaves - truth.ignore, t.subparts)
              for t in truths]
    result: dict[str, object] = {ALL: _scope(preds, truths, tax)}
    for kind in KINDS:
        result[kind] = _scope([p for p in preds if p.kind == kind], [t for t in truths if t.kind == kind], tax)
    if tree is not None and truth.body is not None:
        result[BODY] = score_body(truth.body, _read_body(graph, tax), scored_joints(truth, tree), tax)
    else:
        result[BODY] = _undefined_body()
    result["partitions"] = chosen
    result["differences"] = differences(preds, truths, tax)
    result["failed"] = False
    return result


def differences(preds: list[PredictedComponent], truths: list[TruthComponent], tax: _Taxonomy) -> list[str]:
    """What a robot's prediction gets wrong, one line each: missed and extra components, classes
    without full credit, roots outside the accepted ones, sub-parts without full credit."""
    pairs = _match(preds, truths, tax)
    matched_preds, matched_truths = {id(p) for p, _ in pairs}, {t.id for _, t in pairs}
    found = [f"missed {t.id} ({t.kind}, {'|'.join(sorted(t.classes))}): {sorted(t.leaves)}"
             for t in truths if t.id not in matched_truths]
    found += [f"extra {p.cls} ({p.kind}) on {p.root}: {sorted(p.leaves)}" for p in preds if id(p) not in matched_preds]
    kinds = _kind_roots().values()
    subpart_roots = [kind.subparts for kind in vocabulary().kinds.values()]
    for p, t in pairs:
        if (credit := tax.credit(p.cls, t.classes, kinds)) < 1:
            found.append(f"typed {t.id} {p.cls}, truth {'|'.join(sorted(t.classes))} (credit {credit:g})")
        if p.root not in t.roots:
            found.append(f"root of {t.id} {p.root}, truth {'|'.join(sorted(t.roots))}")
        for leaf, accepted in t.subparts.items():
            if tax.credit(p.subparts.get(leaf), accepted, subpart_roots) < 1:
                found.append(f"subpart {leaf} of {t.id} {p.subparts.get(leaf)}, truth {'|'.join(sorted(accepted))}")
    return found


def end_effector_joints(truth: Truth, tree: KinematicTree) -> frozenset[str]:
    """The joints of the truth's end-effectors: those on the path from an end-effector's root to
    one of its leaves. Of several accepted roots the one nearest the leaf is taken (the roots
    list alternatives such as the wrist roll link or the wrist flex link above it, and the joint
    between them is an arm joint, not the gripper's); a leaf with none of its roots above it
    adds nothing. Canonical components only: the alternatives re-partition the same leaves."""
    out: set[str] = set()
    for comp in truth.components:
        if comp.kind != END_EFFECTOR:
            continue
        for leaf in comp.leaves:
            if leaf not in tree.links:
                continue
            chain = tree.chain_to_root(leaf)
            above = [chain.index(r) for r in comp.roots if r in chain]
            if above:
                out.update(tree.edge_to(link).joint for link in chain[:min(above)])
    return frozenset(out)


def scored_joints(truth: Truth, tree: KinematicTree) -> frozenset[str]:
    """The movable joints (URDF type not ``fixed``; a fixed joint named by a transmission is still
    fixed here) minus the body's ``ignore_joints`` and minus :func:`end_effector_joints`."""
    ignore = truth.body.ignore_joints if truth.body else frozenset()
    movable = {e.joint for e in tree.edges if e.joint_type != "fixed"}
    return frozenset(movable - ignore - end_effector_joints(truth, tree))


def _undefined_body() -> dict:
    return {**dict.fromkeys(BODY_METRICS), **dict.fromkeys(BODY_COUNTS, 0)}


def _share(hits: list, listed: bool) -> float | None:
    """Mean of ``hits``; with none, 0 where the truth lists something to score, else undefined."""
    return fmean(hits) if hits else (0.0 if listed else None)


def score_body(body: TruthBody, preds: list[PredictedBodyPart], scored: frozenset[str], tax: _Taxonomy) -> dict:
    """The body metrics of spec/evaluation.md ("Whole body") for one robot.

    Conventions the spec leaves open (also in the README, "Accuracy and speed"):

    * Both sides' joint sets are cut to ``scored`` before matching. Matching is one-to-one; the
      truth parts with joints are matched first (equal scored joint sets), then those without
      (a prediction whose most specific class is one of ``classes`` and whose ``hasLink``s hold
      the truth's first ``links`` entry: an ancestor class does not identify a part, it only
      earns half credit in a match made on joints). Among several candidates the best typed
      wins, then the one with fewest scored joints.
    * A predicted part left with no scored joint (all its joints ignored, end-effector joints or
      fixed, or none at all) that matches no jointless truth part is not a prediction: it is not
      counted in precision, as a component with no scored leaf is not.
    * Typed credit: 1 for an accepted class, 0.5 for a strict ancestor of one that is itself
      strictly below ``BodyPart``, else 0. A robot with no truth part and none predicted scores
      part and typed precision, recall and F1 of 1; predicting one there makes precision 0.
    * Side accuracy is over matched parts whose truth has a ``side``; a predicted side on a truth
      part without one is not scored. Body root accuracy is over matched parts with ``roots``.
      Either is 0 when the truth has such parts but none matched, undefined (None) when it has none.
    * Joint accuracy is over the scored joints that a truth part lists (the truth files list all
      of them; tests check it). A joint claimed by ``hasJoint`` from no predicted part, or from
      several (hedging), scores 0; otherwise its part's typed credit against the truth part
      owning the joint, or 0 if that truth part has a side and the predicted side differs.
      Undefined for a robot with no scored joint.
    """
    floors = (vocabulary().body_part,)
    own = {p.node: p.joints & scored for p in preds}
    parts = [TruthBodyPart(t.id, t.classes, t.roots, t.joints & scored, t.links, t.side) for t in body.parts]

    def credit(p: PredictedBodyPart, t: TruthBodyPart) -> float:
        return tax.credit(p.cls, t.classes, floors)

    free, pairs = list(preds), []
    for t in [t for t in parts if t.joints] + [t for t in parts if not t.joints]:
        if t.joints:
            cands = [p for p in free if own[p.node] == t.joints]
        else:
            cands = [p for p in free if p.cls in t.classes and t.links and t.links[0] in p.links]
        if cands:
            best = max(cands, key=lambda p: (credit(p, t), -len(own[p.node])))
            free.remove(best)
            pairs.append((best, t))
    matched = {p.node for p, _ in pairs}
    counted = [p for p in preds if own[p.node] or p.node in matched]
    out: dict[str, float | None] = dict(zip(("part_precision", "part_recall", "part_f1"), _prf(len(pairs), len(counted), len(parts))))
    typed = sum(credit(p, t) for p, t in pairs)
    out.update(zip(("typed_precision", "typed_recall", "typed_f1"), _prf(typed, len(counted), len(parts))))
    out["side_accuracy"] = _share([p.side == t.side for p, t in pairs if t.side], any(t.side for t in parts))
    out["root_accuracy"] = _share([p.root in t.roots for p, t in pairs if t.roots], any(t.roots for t in parts))
    owner = {j: t for t in parts for j in t.joints}
    joints = []
    for j in sorted(owner):
        claims = [p for p in preds if j in p.joints]
        t = owner[j]
        ok = len(claims) == 1 and (t.side is None or claims[0].side == t.side)
        joints.append(credit(claims[0], t) if ok else 0.0)
    out["joint_accuracy"] = fmean(joints) if joints else None
    out.update(n_predicted=len(counted), n_truth=len(parts), n_matched=len(pairs), n_joints=len(joints))
    return out


def failed_scores() -> dict:
    """Scores of a robot whose run failed: every metric and count 0, the body's too."""
    zero = {**dict.fromkeys(METRICS, 0.0), **dict.fromkeys(COUNTS, 0)}
    body = {**dict.fromkeys(BODY_METRICS, 0.0), **dict.fromkeys(BODY_COUNTS, 0)}
    return {**{s: dict(zero) for s in SCOPES}, BODY: body, "partitions": {}, "differences": ["run failed"], "failed": True}


def mean_scores(per_robot: Mapping[str, dict]) -> dict:
    """Mean of each metric over robots (failed ones included as 0, undefined values skipped); counts are summed."""
    runs = list(per_robot.values())

    def mean(values: list) -> float | None:
        defined = [v for v in values if v is not None]
        return fmean(defined) if defined else None
    out: dict[str, object] = {s: {**{m: mean([r[s][m] for r in runs]) for m in METRICS},
               **{c: sum(r[s][c] for r in runs) for c in COUNTS}} for s in SCOPES}
    out[BODY] = {**{m: mean([r[BODY][m] for r in runs]) for m in BODY_METRICS},
                 **{c: sum(r[BODY][c] for r in runs) for c in BODY_COUNTS}}
    out["failed"] = sum(bool(r.get("failed")) for r in runs)
    return out


_HEADERS = {
    "leaf_precision": "leafP", "leaf_recall": "leafR", "leaf_f1": "leafF1",
    "component_precision": "compP", "component_recall": "compR", "component_f1": "compF1",
    "typed_precision": "typedP", "typed_recall": "typedR", "typed_f1": "TYPED_F1",
    "root_accuracy": "root", "subpart_accuracy": "subpart",
}
_BODY_HEADERS = {
    "part_precision": "partP", "part_recall": "partR", "part_f1": "partF1",
    "typed_precision": "typedP", "typed_recall": "typedR", "typed_f1": "BODY_F1",
    "side_accuracy": "side", "root_accuracy": "root", "joint_accuracy": "joint",
}


def _cell(value: float | None) -> str:
    return "-" if value is None else f"{value:.3f}"


def _table(rows: list[list[str]]) -> list[str]:
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    lines = ["  ".join(c.ljust(w) if i == 0 else c.rjust(w) for i, (c, w) in enumerate(zip(r, widths)))
             for r in rows]
    return [lines[0], "-" * len(lines[0]), *lines[1:]]


def load_folds(path: str | Path) -> dict[str, list[str]]:
    """The folds of a folds file (benchmarks/folds.yaml): fold name -> its robots (truth file stems)."""
    data = yaml.safe_load(Path(path).read_text())
    if not isinstance(data, dict) or not all(isinstance(v, dict) for v in data.values()):
        raise UrdfkbError(f"{path}: expected fold names mapping robots to their families")
    return {str(fold): list(robots) for fold, robots in data.items()}


def fold_means(per_robot: Mapping[str, dict], folds: Mapping[str, list[str]]) -> dict[str, dict]:
    """mean_scores over each fold's robots that were run (folds none of whose robots ran are left out)."""
    out = {}
    for fold, robots in folds.items():
        runs = {r: per_robot[r] for r in robots if r in per_robot}
        if runs:
            out[fold] = mean_scores(runs)
    return out


def format_table(per_robot: Mapping[str, dict], extra_columns: Mapping[str, Mapping[str, object]] | None = None,
                 folds: Mapping[str, list[str]] | None = None) -> str:
    """Plain-text report: one block per scope (all, sensor, end_effector), rows the robots and
    their mean (and each of `folds`' means), columns the metrics (the headline is TYPED_F1), then the
    "body" block (its headline BODY_F1, the typed body-part F1). ``extra_columns`` maps a column
    title to ``{robot: value}`` (e.g. model, voting, LLM calls, tokens, wall time), shown in a
    final "run" block; a value under the key ``"mean"`` fills the mean row.
    """
    names = list(per_robot)
    means = {"mean": mean_scores(per_robot), **{f"mean {f}": m for f, m in fold_means(per_robot, folds or {}).items()}}
    label = {n: n + (" (failed)" if per_robot[n].get("failed") else "") for n in names} | {m: m for m in means}
    blocks = []
    for scope, metrics, headers in [*((s, METRICS, _HEADERS) for s in SCOPES), (BODY, BODY_METRICS, _BODY_HEADERS)]:
        rows = [[scope, *(headers[m] for m in metrics)]]
        rows += [[label[n], *(_cell(per_robot[n][scope][m]) for m in metrics)] for n in names]
        rows += [[label[k], *(_cell(mean[scope][m]) for m in metrics)] for k, mean in means.items()]
        blocks.append("\n".join(_table(rows)))
    if extra_columns:
        cols = list(extra_columns)
        rows = [["run", *cols]]
        rows += [[label[n], *(str(extra_columns[c].get(n, "")) for c in cols)] for n in [*names, "mean"]]
        blocks.append("\n".join(_table(rows)))
    return "\n\n".join(blocks) + "\n"
