"""Alike parts decided together beyond identification: a left and a right limb's sensors are mounted, checked and
typed by one question each, whose answer both get, even from a model that would tell them apart.

Generated robots: a body with two mirrored arms (seeded random lengths and meaningless names), each carrying a
camera (a housing with an optical frame) partway along its last segment. The scripted model answers the
left side's questions one way and would answer the right side's another.
"""
from __future__ import annotations

import math
import random

import pytest
from tests.urdf_writer import Writer

from urdfkb.pipeline.abstraction.components import SENSOR
from urdfkb.pipeline.reading.ingest import load_urdf
from urdfkb.pipeline.llm.scripted import ScriptedBackend
from urdfkb.pipeline.abstraction.oracle import Oracle
from urdfkb.pipeline.knowledge.ontology import vocabulary
from urdfkb.pipeline.abstraction.stages.attachment import detect_roots
from urdfkb.pipeline.abstraction.stages.classification import Typed
from urdfkb.pipeline.abstraction.stages.grouping import Group
from urdfkb.pipeline.abstraction.stages.sensor_check import not_sensors
from urdfkb.pipeline.abstraction.stages.subparts import type_subparts
from urdfkb.pipeline.abstraction.alike import alike_leaves

TAX = vocabulary()
SEEDS = range(0, 200, 7)


def _two_armed(seed: int):
    """(urdf, left chain, right chain): each chain runs shoulder → ... → housing → frame (the leaf)."""
    rng = random.Random(seed)
    w = Writer(rng)
    base = w.link('<box size="0.4 0.3 0.5"/>')
    sides = []
    lengths = [rng.uniform(0.15, 0.35) for _ in range(rng.randint(2, 4))]
    for side in (1.0, -1.0):
        parent, chain = base, []
        for k, length in enumerate(lengths):
            link = w.link(f'<cylinder radius="0.04" length="{length:.3f}"/>')
            offset = (0.0, side * 0.2, 0.3) if k == 0 else (0.0, 0.0, -lengths[k - 1])
            w.joint("revolute", parent, link, offset, axis=(0.0, 1.0, 0.0))
            parent = link
            chain.append(link)
        bracket = w.link('<box size="0.02 0.05 0.02"/>')
        w.joint("fixed", parent, bracket, (0.05, 0.0, -lengths[-1] / 2))
        housing = w.link('<box size="0.03 0.08 0.03"/>')
        w.joint("fixed", bracket, housing, (0.02, 0.0, 0.0))
        frame = w.name()
        w.links.append(f'<link name="{frame}"/>')
        w.joint("fixed", housing, frame, (0.0, 0.0, 0.0), rpy=(-math.pi / 2, 0.0, -math.pi / 2))
        sides.append(chain + [bracket, housing, frame])
    return w.urdf(), sides[0], sides[1]


def _leaf(question) -> str:
    return _link(question.key)


def _link(key: str) -> str:
    """The link a question's trace key names ("part:x@Subpart" → "x")."""
    return key.split(":", 1)[1].split("@", 1)[0]


@pytest.mark.parametrize("seed", SEEDS)
def test_alike_sensors_are_mounted_checked_and_typed_by_one_question_each(seed):
    urdf, left, right = _two_armed(seed)
    tree = load_urdf(urdf)
    assert [sorted(g) for g in alike_leaves(tree, [left[-1], right[-1]])] == [sorted([left[-1], right[-1]])]
    asked: list[str] = []

    def fickle(q):
        """The left camera's mount is its bracket, the right one's its housing; left a sensor, right a drive part."""
        asked.append(q.key)
        leaf_is_left = _leaf(q) in left
        if q.key.startswith("root:"):
            return q.options[1] if leaf_is_left else q.options[0]
        if q.key.startswith("check:"):
            return "sensor" if leaf_is_left else q.options[-1]
        return q.options[0] if leaf_is_left else q.options[-1]
    oracle = Oracle(ScriptedBackend(fickle))
    kind = TAX.kinds[SENSOR]
    chains = detect_roots(oracle, tree, [left[-1], right[-1]], kind, lambda _link: False, rigid=True)
    assert len(chains[0].links) == len(chains[1].links) and chains[0].root in left and chains[1].root in right
    assert sum(k.startswith("root:") for k in asked) == 1

    kept = not_sensors(oracle, TAX, tree, [left[-1], right[-1]], {left[-1]: 0.9, right[-1]: 0.9}, lambda _m: None)
    assert kept == [] and sum(k.startswith("check:") for k in asked) == 1

    groups = [Group([c]) for c in chains]
    parts = type_subparts(oracle, TAX, tree, kind, groups, [Typed("MonocularCamera", 0.9)] * 2)
    for a, b in zip(chains[0].links, chains[1].links):
        assert parts[a].cls == parts[b].cls, (a, b)
    part_questions = [k for k in asked if k.startswith("part:")]
    assert part_questions and all(_link(k) in left for k in part_questions)

