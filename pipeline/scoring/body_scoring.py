"""Scoring the whole body of one robot (../shared/spec/evaluation.md, "Whole body"): its body parts and the
joints they hold; the conventions the spec leaves open are score_body's.
"""
from __future__ import annotations

from statistics import fmean

from urdfkb.pipeline.scoring.component_scoring import prf
from urdfkb.pipeline.abstraction.components import END_EFFECTOR
from urdfkb.pipeline.knowledge.ontology import vocabulary
from urdfkb.pipeline.scoring.prediction import ClassAncestry, PredictedBodyPart
from urdfkb.pipeline.reading.tree import KinematicTree
from urdfkb.pipeline.scoring.truth import Truth, TruthBody, TruthBodyPart

BODY = "body"
BODY_METRICS = (
    "part_precision", "part_recall", "part_f1",
    "typed_precision", "typed_recall", "typed_f1",
    "side_accuracy", "root_accuracy", "joint_accuracy",
)
BODY_COUNTS = ("n_predicted", "n_truth", "n_matched", "n_joints")


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


def undefined_body() -> dict:
    return {**dict.fromkeys(BODY_METRICS), **dict.fromkeys(BODY_COUNTS, 0)}


def _share(hits: list, listed: bool) -> float | None:
    """Mean of ``hits``; with none, 0 where the truth lists something to score, else undefined."""
    return fmean(hits) if hits else (0.0 if listed else None)


def score_body(body: TruthBody, preds: list[PredictedBodyPart], scored: frozenset[str], ancestry: ClassAncestry) -> dict:
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
        return ancestry.credit(p.cls, t.classes, floors)

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
    out: dict[str, float | None] = dict(zip(("part_precision", "part_recall", "part_f1"), prf(len(pairs), len(counted), len(parts))))
    typed = sum(credit(p, t) for p, t in pairs)
    out.update(zip(("typed_precision", "typed_recall", "typed_f1"), prf(typed, len(counted), len(parts))))
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
