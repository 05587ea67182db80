"""A generated robot for the property-restriction loop, and a scripted model that takes its torso's frames for
bumpers: a wheeled base carrying a bumper frame and, on a prismatic lift (a torso), a button frame and a pad of
two frames on one housing; every name a seeded meaningless stem (tests/urdf_writer.py)."""
from __future__ import annotations

import random
from dataclasses import dataclass
from typing import Callable

from tests.urdf_writer import Writer
from urdfkb.pipeline.llm.base import Question
from urdfkb.pipeline.knowledge.ontology import vocabulary

TAX = vocabulary()
LABELS = {TAX.answer(c): c for c in TAX.subclasses_below(TAX.component)}


@dataclass
class Robot:
    urdf: bytes
    lift: str                # the torso's lifting joint
    button: str              # a frame on the torso
    pad: tuple[str, str]     # two frames of one device on the torso
    bumper: str              # a frame on the base
    wheels: tuple[str, str]  # their links


def build(seed: int) -> Robot:
    """A wheeled base carrying a bumper frame and, on a prismatic lift, a torso carrying a button frame and a
    housing with two pad frames; every name a seeded meaningless stem."""
    w = Writer(random.Random(seed))
    base = w.link('<box size="0.6 0.5 0.2"/>')
    wheels = []
    for y in (0.25, -0.25):
        wheels.append(w.link('<cylinder radius="0.08" length="0.04"/>'))
        w.joint("continuous", base, wheels[-1], (0, y, -0.05), (0, 1, 0))
    torso = w.link('<box size="0.2 0.3 0.6"/>')
    lift = w.joint("prismatic", base, torso, (0, 0, 0.3))
    bumper, button, housing = w.link(), w.link(), w.link('<box size="0.05 0.1 0.02"/>')
    w.joint("fixed", base, bumper, (0.3, 0, 0))
    w.joint("fixed", torso, button, (0.1, 0, 0.4))
    w.joint("fixed", torso, housing, (0.1, 0, 0.2))
    pad = (w.link(), w.link())
    for y, frame in zip((0.03, -0.03), pad):
        w.joint("fixed", housing, frame, (0.01, y, 0))
    return Robot(w.urdf(), lift, button, pad, bumper, (wheels[0], wheels[1]))


def model(robot: Robot, asked: list[Question]) -> Callable[[Question], str]:
    """Every frame is a contact sensor, and a bumper wherever it may be one (else a button, the pad's two frames a
    tactile array); the lift is a torso; each question is recorded in `asked`. (The pad's frames hang from one
    housing: one device by structure.)"""

    def rule(q: Question) -> str:
        asked.append(q)
        stage, _, subject = q.key.partition(":")
        subject = subject.partition("@")[0]
        if stage == "identify":
            return "body part" if subject in robot.wheels else "sensor"
        if stage == "body":
            return "torso" if subject == robot.lift else "none"
        if stage == "root":
            return q.options[-1]  # the farthest mount offered: the pad's housing is then inside both its chains
        if stage == "check":
            return "sensor"
        if stage in ("device", "side"):
            return q.options[0]
        if stage == "part":
            return next(o for o in q.options if LABELS.get(o) == "SensingElement")
        wanted = ("Bumper", "TactileArray" if subject in robot.pad else "Button", "ContactSensor")
        return next(o for cls in wanted for o in q.options if TAX.is_a(cls, LABELS[o]))
    return rule
