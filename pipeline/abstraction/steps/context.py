"""What a step works with besides the findings record: the robot, the tree its pass sees, the pass's
component kind, the model, the vocabulary, the reasoner and the counts kept over the robot's run."""
from __future__ import annotations

import json
from dataclasses import dataclass
from typing import Callable

from urdfkb.pipeline.knowledge import reasoning
from urdfkb.pipeline.knowledge.ontology import Kind, Vocabulary
from urdfkb.pipeline.abstraction.oracle import Oracle
from urdfkb.pipeline.abstraction.stages.asking import Progress
from urdfkb.pipeline.reading.tree import KinematicTree

Log = Callable[[str], None]


@dataclass
class Tally:
    """Counts over one robot's run: for its provenance and the steps' timing records."""

    declared: int = 0  # classification subjects whose options a simulator sensor declaration narrowed
    reasoner_seconds: float = 0.0  # the reasoner's wall time


@dataclass(frozen=True)
class Context:
    """One pass's view of one robot. `reasoner` classifies tools and body candidates from their facts,
    `placer` says which classes a body part rules out for what sits on it (pipeline.knowledge.reasoning)."""

    robot: KinematicTree  # the whole robot
    tree: KinematicTree  # what the pass sees: the robot less the devices of earlier device passes
    kind: Kind | None  # the component kind the pass finds (None: the body pass)
    oracle: Oracle
    vocab: Vocabulary
    progress: Progress | None
    log: Log
    reasoner: reasoning.Reasoner
    placer: reasoning.Placer
    tally: Tally

    @property
    def device_kind(self) -> Kind:
        """The kind the pass finds; ValueError in the body pass, which finds none."""
        if self.kind is None:
            raise ValueError("a step of the device passes ran in a pass that finds no component kind")
        return self.kind

    def trace(self, record: dict) -> None:
        """Write `record` to the oracle's trace, if it keeps one."""
        write_trace(self.oracle, record)


def write_trace(oracle: Oracle, record: dict) -> None:
    """Write `record` to `oracle`'s trace, if it keeps one."""
    if oracle.trace is not None:
        oracle.trace.write(json.dumps(record) + "\n")
