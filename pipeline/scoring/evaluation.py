"""Abstraction accuracy against the ground truth, as defined in ../shared/spec/evaluation.md: every metric of
one robot (components: pipeline.scoring.component_scoring; the whole body: pipeline.scoring.body_scoring), and their means over
robots and folds.
"""
from __future__ import annotations

from statistics import fmean
from typing import Mapping

import rdflib

from urdfkb.pipeline.scoring.body_scoring import BODY, BODY_COUNTS, BODY_METRICS, score_body, scored_joints, undefined_body
from urdfkb.pipeline.scoring.component_scoring import (ALL, COUNTS, METRICS, SCOPES, choose_partition, differences,
                                               score_scope)
from urdfkb.pipeline.abstraction.components import KINDS
from urdfkb.pipeline.scoring.prediction import ClassAncestry, read_body, read_prediction
from urdfkb.pipeline.reading.tree import KinematicTree
from urdfkb.pipeline.scoring.truth import Truth, TruthComponent


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
    ancestry = ClassAncestry(graph)
    scorable = set(urdf_leaves) - truth.ignore
    preds = [p for p in read_prediction(graph, scorable, ancestry) if p.leaves]
    truths, chosen = choose_partition(truth, preds, ancestry)
    truths = [TruthComponent(t.id, t.kind, t.classes, t.roots, t.leaves - truth.ignore, t.subparts)
              for t in truths]
    result: dict[str, object] = {ALL: score_scope(preds, truths, ancestry)}
    for kind in KINDS:
        result[kind] = score_scope([p for p in preds if p.kind == kind], [t for t in truths if t.kind == kind], ancestry)
    if tree is not None and truth.body is not None:
        result[BODY] = score_body(truth.body, read_body(graph, ancestry), scored_joints(truth, tree), ancestry)
    else:
        result[BODY] = undefined_body()
    result["partitions"] = chosen
    result["differences"] = differences(preds, truths, ancestry)
    result["failed"] = False
    return result


def failed_scores() -> dict:
    """Scores of a robot whose run failed: every metric and count 0, the body's too."""
    zero = {**dict.fromkeys(METRICS, 0.0), **dict.fromkeys(COUNTS, 0)}
    body = {**dict.fromkeys(BODY_METRICS, 0.0), **dict.fromkeys(BODY_COUNTS, 0)}
    return {**{scope: dict(zero) for scope in SCOPES}, BODY: body, "partitions": {}, "differences": ["run failed"], "failed": True}


def mean_scores(per_robot: Mapping[str, dict]) -> dict:
    """Mean of each metric over robots (failed ones included as 0, undefined values skipped); counts are summed."""
    runs = list(per_robot.values())

    def mean(values: list) -> float | None:
        defined = [v for v in values if v is not None]
        return fmean(defined) if defined else None
    out: dict[str, object] = {scope: {**{m: mean([r[scope][m] for r in runs]) for m in METRICS},
                                      **{c: sum(r[scope][c] for r in runs) for c in COUNTS}} for scope in SCOPES}
    out[BODY] = {**{m: mean([r[BODY][m] for r in runs]) for m in BODY_METRICS},
                 **{c: sum(r[BODY][c] for r in runs) for c in BODY_COUNTS}}
    out["failed"] = sum(bool(r.get("failed")) for r in runs)
    return out


def fold_means(per_robot: Mapping[str, dict], folds: Mapping[str, list[str]]) -> dict[str, dict]:
    """mean_scores over each fold's robots that were run (folds none of whose robots ran are left out)."""
    out = {}
    for fold, robots in folds.items():
        runs = {r: per_robot[r] for r in robots if r in per_robot}
        if runs:
            out[fold] = mean_scores(runs)
    return out
