"""Generated sensor heads where a device's own IMU frame is its only leaf (a lidar written as a housing frame
with its built-in IMU's frame below), and a model that types every IMU frame an IMU, as the small model does
(tests/test_built_in_frames.py)."""
from __future__ import annotations

import random

from tests.toy_robot import LABELS, TAX
from tests.urdf_writer import Writer
from urdfkb.pipeline.llm.base import Question


def build(seed: int):
    """A head with 1-3 lidars (housing: a bare frame or a box) each carrying only its IMU's frame, one IMU
    (a box with its frame), one carrier (a box with an IMU frame and a pad the model calls no sensor, which
    the model also calls a lidar) and one bracket (a box with an IMU frame, which the model cannot place);
    returns the URDF, the head, each housing's class as the model reads it, each frame's housing and each
    frame's true class."""
    rng = random.Random(seed)
    w = Writer(rng)
    base = w.link('<box size="0.4 0.4 0.2"/>')
    head = w.link('<box size="0.2 0.2 0.1"/>')
    w.joint("fixed", base, head, (0.0, 0.0, 0.5))
    truth: dict[str, str] = {}
    frame_of: dict[str, str] = {}
    expected: dict[str, str] = {}
    kinds = ["Lidar"] * rng.randint(1, 3) + ["IMU", "carrier", "bracket"]
    rng.shuffle(kinds)
    for cls in kinds:
        bare = cls == "Lidar" and rng.random() < 0.5
        housing = w.link("" if bare else '<box size="0.05 0.05 0.05"/>')
        w.joint("fixed", head, housing, (rng.uniform(-0.1, 0.1), rng.uniform(-0.1, 0.1), 0.05),
                rpy=(0.0, rng.uniform(-0.8, 0.8), rng.uniform(-3.0, 3.0)))
        frame = w.name()
        w.links.append(f'<link name="{frame}"/>')
        w.joint("fixed", housing, frame, (0.008, -0.009, -0.039))
        if cls == "carrier":
            w.joint("fixed", housing, w.link('<box size="0.01 0.02 0.02"/>'), (0.03, 0.0, 0.0))
        truth[housing], frame_of[frame] = "Lidar" if cls == "carrier" else cls, housing
        expected[frame] = "IMU" if cls in ("carrier", "bracket") else cls
    return w.urdf(), head, truth, frame_of, expected


def reads_frames(head: str, truth: dict[str, str], frame_of: dict[str, str]):
    """A model that knows each housing, and types every IMU frame an IMU, whatever carries it."""
    def answer(q: Question) -> str | dict[str, float]:
        stage, _, subject = q.key.partition(":")
        subject = subject.partition("@")[0]
        if stage == "identify":
            return "sensor" if subject in frame_of else q.options[-1]
        if stage == "check":
            return "sensor"
        if stage == "root":
            return head if head in q.options else q.options[-1]
        if stage == "device":
            return q.options[-1]
        if stage == "pre" and truth.get(subject) == "bracket":  # a bracket: the model cannot place it
            return {o: (0.4 if o == "contact sensor" else 0.6 / (len(q.options) - 1)) for o in q.options}
        if stage == "pre":
            cls = "IMU" if subject in frame_of else truth[subject]
            return next(o for o in q.options if o in LABELS and TAX.is_a(cls, LABELS[o]))
        return q.options[0]
    return answer
