"""Scoring the components of one robot (../shared/spec/evaluation.md), per scope (both kinds, each kind).

Conventions beyond the spec:

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
"""
from __future__ import annotations

from statistics import fmean

from urdfkb.pipeline.abstraction.components import KINDS
from urdfkb.pipeline.knowledge.ontology import vocabulary
from urdfkb.pipeline.scoring.prediction import ClassAncestry, PredictedComponent, kind_roots
from urdfkb.pipeline.scoring.truth import Truth, TruthComponent
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


def prf(hits: float, n_pred: int, n_truth: int) -> tuple[float, float, float]:
    """Precision, recall and F1 of `hits` (matches, or their credit) among `n_pred` predictions and `n_truth` truths."""
    if not n_truth:  # nothing to find: recall holds vacuously, and any prediction is wrong
        return (0.0, 1.0, 0.0) if n_pred else (1.0, 1.0, 1.0)
    p = hits / n_pred if n_pred else 0.0
    r = hits / n_truth if n_truth else 0.0
    return p, r, (2 * p * r / (p + r) if p + r else 0.0)


def match(preds: list[PredictedComponent], truths: list[TruthComponent], ancestry: ClassAncestry
          ) -> list[tuple[PredictedComponent, TruthComponent]]:
    """One-to-one pairs with equal leaf sets; among duplicates the best-typed prediction wins."""
    free = list(preds)
    pairs = []
    for t in truths:
        cands = [p for p in free if p.leaves == t.leaves]
        if cands:
            best = max(cands, key=lambda p: ancestry.credit(p.cls, t.classes, kind_roots().values()))
            free.remove(best)
            pairs.append((best, t))
    return pairs


def choose_partition(truth: Truth, preds: list[PredictedComponent], ancestry: ClassAncestry
                     ) -> tuple[list[TruthComponent], dict[str, str]]:
    """Truth components after choosing, per alternatives entry, the partition matching more
    predicted components (over both kinds; a tie keeps the canonical one)."""
    by_id = {c.id: c for c in truth.components}
    comps = list(truth.components)
    chosen = {}
    for alt in truth.alternatives:
        canonical = [by_id[i] for i in alt.replace]
        use_alt = len(match(preds, list(alt.with_), ancestry)) > len(match(preds, canonical, ancestry))
        chosen["+".join(alt.replace)] = "alternative" if use_alt else "canonical"
        if use_alt:
            comps = [c for c in comps if c.id not in alt.replace] + list(alt.with_)
    return comps, chosen


def score_scope(preds: list[PredictedComponent], truths: list[TruthComponent], ancestry: ClassAncestry) -> dict:
    pairs = match(preds, truths, ancestry)
    pred_leaves = set().union(*(p.leaves for p in preds))
    truth_leaves = set().union(*(t.leaves for t in truths))
    out: dict[str, float | None] = dict(zip(("leaf_precision", "leaf_recall", "leaf_f1"),
                   prf(len(pred_leaves & truth_leaves), len(pred_leaves), len(truth_leaves))))
    out.update(zip(("component_precision", "component_recall", "component_f1"),
                   prf(len(pairs), len(preds), len(truths))))
    credits = {p.node: ancestry.credit(p.cls, t.classes, kind_roots().values()) for p, t in pairs}
    typed = sum(credits.values())
    out.update(zip(("typed_precision", "typed_recall", "typed_f1"), prf(typed, len(preds), len(truths))))
    out["root_accuracy"] = (fmean(p.root in t.roots for p, t in pairs) if pairs else 0.0) if truths else None
    subpart_roots = [kind.subparts for kind in vocabulary().kinds.values()]
    sub = [ancestry.credit(p.subparts.get(leaf), accepted, subpart_roots)
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


def differences(preds: list[PredictedComponent], truths: list[TruthComponent], ancestry: ClassAncestry) -> list[str]:
    """What a robot's prediction gets wrong, one line each: missed and extra components, classes
    without full credit, roots outside the accepted ones, sub-parts without full credit."""
    pairs = match(preds, truths, ancestry)
    matched_preds, matched_truths = {id(p) for p, _ in pairs}, {t.id for _, t in pairs}
    found = [f"missed {t.id} ({t.kind}, {'|'.join(sorted(t.classes))}): {sorted(t.leaves)}"
             for t in truths if t.id not in matched_truths]
    found += [f"extra {p.cls} ({p.kind}) on {p.root}: {sorted(p.leaves)}" for p in preds if id(p) not in matched_preds]
    kinds = kind_roots().values()
    subpart_roots = [kind.subparts for kind in vocabulary().kinds.values()]
    for p, t in pairs:
        if (credit := ancestry.credit(p.cls, t.classes, kinds)) < 1:
            found.append(f"typed {t.id} {p.cls}, truth {'|'.join(sorted(t.classes))} (credit {credit:g})")
        if p.root not in t.roots:
            found.append(f"root of {t.id} {p.root}, truth {'|'.join(sorted(t.roots))}")
        for leaf, accepted in t.subparts.items():
            if ancestry.credit(p.subparts.get(leaf), accepted, subpart_roots) < 1:
                found.append(f"subpart {leaf} of {t.id} {p.subparts.get(leaf)}, truth {'|'.join(sorted(accepted))}")
    return found
