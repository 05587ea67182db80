"""Stage 1 for sensors, the sensor check: leaves identified as sensors that are none after all.

- A leaf that itself moves on a <mimic> joint is a finger segment or a linkage, never a sensor frame
  (a sensor is fixed to what carries it): it is left for the end-effector pass, whose tools keep
  every finger chain.
- Every other leaf identified as a sensor is asked once more, framed differently (sensor, emitter,
  drive part or reference frame?), unless the file declares a simulator sensor on it. Only "part of
  a motor or drive" overrules identification: over the ten truth robots it went to motor screws and
  an actuator's dummy link and to no true sensor, while 'emitter' and 'reference frame' also took
  laser scanners and optical frames, so they are traced but change nothing.
"""
from __future__ import annotations

from urdfkb.pipeline.evidence import named
from urdfkb.pipeline.oracle import Oracle
from urdfkb.pipeline.prompts import DRIVE_PART, sensor_check
from urdfkb.pipeline.stages.asking import Progress, ask
from urdfkb.pipeline.stages.verification import Log
from urdfkb.pipeline.tree import KinematicTree


def coupled(tree: KinematicTree, leaves: list[str], sensors: set[str], log: Log) -> list[str]:
    """The leaves among `sensors` that move on a <mimic> joint."""
    found = []
    for leaf in leaves:
        if leaf in sensors and tree.parent_edge(leaf).mimic is not None:
            found.append(leaf)
            log(f"not a sensor: {leaf} moves on mimic joint {tree.parent_edge(leaf).joint}")
    return found


def drive_parts(oracle: Oracle, tree: KinematicTree, leaves: list[str], sensors: set[str], log: Log,
                progress: Progress | None = None) -> list[str]:
    """The leaves among `sensors` with no declared simulator sensor that the check calls a part of a
    motor or drive."""
    checked = [leaf for leaf in leaves if leaf in sensors and not _declared(tree, leaf)]
    questions = [sensor_check(leaf, named(tree.evidence, leaf), tree.chain_to_root(leaf)[1:]) for leaf in checked]
    found = []
    for leaf, verdict in zip(checked, ask(oracle, questions, "sensor check", progress)):
        if verdict.answer == DRIVE_PART:
            found.append(leaf)
            log(f"not a sensor: {leaf} is a part of a motor or drive ({verdict.confidence:.2f})")
    return found


def _declared(tree: KinematicTree, leaf: str) -> bool:
    facts = tree.evidence.get(leaf)
    return facts is not None and bool(facts.sensors)
