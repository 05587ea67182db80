"""Run the pipeline on one ground-truth robot and score it: what `urdfkb eval` and the benchmarks share."""
from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path
from typing import TextIO

from urdfkb.pipeline.scoring import evaluation

from urdfkb.pipeline.knowledge import rdf
from urdfkb.pipeline.scoring.truth import load_truth
from urdfkb.pipeline.abstraction.components import Abstraction
from urdfkb.pipeline.knowledge.export import robot_graph
from urdfkb.pipeline.reading.ingest import load_urdf
from urdfkb.pipeline.llm.base import Backend
from urdfkb.pipeline.knowledge.population import build_robot
from urdfkb.pipeline.runner import Progress, Settings, run


@dataclass(frozen=True)
class RobotRun:
    """One truth robot's scores, the abstraction behind them and the wall time (ingestion included)."""

    robot: str
    scores: dict
    abstraction: Abstraction
    seconds: float


def run_truth_robot(truth_path: str | Path, settings: Settings, backend: Backend | None = None,
                    progress: Progress | None = None, trace: TextIO | None = None) -> RobotRun:
    """The URDF named by the truth file (relative to the truth folder's grandparent), abstracted and scored."""
    truth = load_truth(truth_path)
    urdf = Path(truth_path).resolve().parent.parent.parent / truth.urdf
    started = time.monotonic()
    tree = load_urdf(urdf)
    abstraction = run(tree, settings, backend=backend, progress=progress, trace=trace)
    seconds = time.monotonic() - started
    graph = robot_graph(build_robot(rdf.new_world(), tree, truth.robot, abstraction))
    return RobotRun(truth.robot, evaluation.score(truth, graph, set(tree.leaves()), tree), abstraction, seconds)
