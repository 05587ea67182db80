"""The evaluation as plain text: the per-robot table of `urdfkb eval` and the line on its review queue."""
from __future__ import annotations

from typing import Mapping

from urdfkb.pipeline.scoring.body_scoring import BODY, BODY_METRICS
from urdfkb.pipeline.scoring.component_scoring import ALL, METRICS, SCOPES
from urdfkb.pipeline.scoring.evaluation import fold_means, mean_scores
from urdfkb.settings import REVIEW_THRESHOLD


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
