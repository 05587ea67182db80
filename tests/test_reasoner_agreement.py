"""The scripted reasoner (tests/scripted_reasoner.py) answers as HermiT does: on the toy's pipeline run,
on generated hands and grippers, on generated bodies (their candidates carrying class names, and
carrying tools of the same run) and on candidates either side of each body-part condition; and its
placements (what each body part rules out for what sits on it) over every body class and component class."""
from __future__ import annotations

from dataclasses import replace

import pytest

from tests.body_robots import legged, wheeled
from tests.hand_robots import build
from tests.scripted_reasoner import scripted_placements, scripted_reasoner
from tests.toy_robot import TAX, TOY, perfect
from urdfkb.pipeline.abstraction.abstractor import Abstractor
from urdfkb.pipeline.abstraction.components import END_EFFECTOR
from urdfkb.pipeline.reading.ingest import load_urdf
from urdfkb.pipeline.llm.scripted import ScriptedBackend
from urdfkb.pipeline.abstraction.oracle import Oracle
from urdfkb.pipeline.knowledge.reasoning import TOOL_REF, PartFacts, classify_together, placements
from urdfkb.pipeline.abstraction.stages import body
from urdfkb.pipeline.abstraction.structure import ToolStructure, tool_structure

Call = tuple[list[ToolStructure], list[PartFacts]]


def toy_run() -> list[Call]:
    """What the pipeline gives the reasoner on the toy robot (tools and body candidates in one run)."""
    calls: list[Call] = []

    def recording(tools, parts):
        calls.append((tools, parts))
        return scripted_reasoner(tools, parts)
    Abstractor(Oracle(ScriptedBackend(perfect)), TAX, reasoner=recording).run(load_urdf(TOY))
    return calls


def generated_body(built, tools_in_run: bool) -> Call:
    """A generated robot's body candidates as the body pass asserts them: its grippers by their class, or
    (`tools_in_run`) as the end-effector pass's run has them, tools of the same run."""
    tree = load_urdf(built.urdf)
    grippers = [c for c in built.components if c.kind == END_EFFECTOR] if tools_in_run else []
    tools = [tool_structure(tree, [link for link in c.links if tree.is_leaf(link)]) for c in grippers]
    ref = {c.name: f"{TOOL_REF}{i}" for i, c in enumerate(grippers)}
    components = [replace(c, cls=ref.get(c.name, c.cls)) for c in body.with_joints(tree, built.components)]
    return tools, body.findings(tree, body.candidates(tree, components), components).facts


def boundaries() -> Call:
    """Candidates on both sides of each body-part condition: one to five joints (one continuous), a camera,
    a tool, another sensor, both or nothing, carrying a wheel, another part, one or two parts with tools or none,
    on the ground or off it, a camera near the first joint or far out, turning about the vertical or not, sliding
    only or not."""
    wheel, other = PartFacts(("continuous",), (), (), True), PartFacts(("revolute", "revolute"), (), (), False)
    arm = PartFacts(("revolute",) * 6, ("ParallelGripper",), (), False)
    joints = [("continuous",), ("revolute",), ("revolute", "continuous"), ("revolute", "revolute", "prismatic"),
              ("revolute",) * 4, ("revolute",) * 5]
    devices = [(), ("MonocularCamera",), ("ParallelGripper",), ("Lidar",), ("RGBDCamera", "ParallelGripper")]
    return [], [wheel, other, arm, arm,
                *(PartFacts(j, d, carries, ground) for j in joints for d in devices
                  for carries in ((), (0,), (1,)) for ground in (True, False)),
                *(PartFacts(("prismatic",), d, carries, ground) for d in devices
                  for carries in ((2,), (2, 3), (1, 2)) for ground in (True, False)),
                *(PartFacts(j, ("MonocularCamera",), (), False, span=span) for j in joints[:4]
                  for span in (0.3, 0.5, 0.5004, 0.501, 1.95)),
                *(PartFacts(j, d, (), ground, vertical=True) for j in joints[:3] for d in devices[:2]
                  for ground in (True, False)),
                *(PartFacts(("prismatic",) * n, d, (), ground, sliding=True) for n in (1, 3) for d in devices[:3]
                  for ground in (True, False))]


def carried() -> Call:
    """A second round's candidates: parts of asserted classes (arms on either side, on no side, a head, a leg) and
    candidates carrying them on the ground or off it."""
    two = ("revolute", "revolute")
    known = [PartFacts(two, (), (), False, "left", "Arm"), PartFacts(two, (), (), False, "right", "Arm"),
             PartFacts(("revolute",), (), (), False, None, "Head"), PartFacts(two, (), (), True, "left", "Leg"),
             PartFacts(two, (), (), False, None, "Arm")]
    carriers = [PartFacts(("revolute",), (), carries, ground)
                for carries in ((0, 1), (0,), (0, 2), (3, 1), (0, 4)) for ground in (True, False)]
    return [], known + carriers


def suspended() -> Call:
    """Chains of one-joint candidates down to a wheel (a suspension carrying a steering knuckle carrying a wheel, and
    a part carrying that suspension), one of them with a tool, a two-joint part carrying a knuckle, and one-joint
    parts carrying a part asserted a mobile base that carries no wheel, and one that does."""
    wheel, knuckle = PartFacts(("continuous",), (), (), True), PartFacts(("revolute",), (), (0,), True)
    return [], [wheel, knuckle, PartFacts(("prismatic",), (), (1,), True), PartFacts(("prismatic",), (), (2,), False),
                PartFacts(("prismatic",), ("ParallelGripper",), (1,), False),
                PartFacts(("prismatic", "revolute"), (), (1,), False),
                PartFacts(("revolute", "revolute"), (), (), False, known="MobileBase"),
                PartFacts(("prismatic",), (), (6,), False),
                PartFacts(("revolute",), (), (0,), False, known="MobileBase"), PartFacts(("prismatic",), (), (8,), False)]


def merged(calls: list[Call]) -> Call:
    """The calls as one: each part's followers and same-run tools renumbered."""
    tools: list[ToolStructure] = []
    parts: list[PartFacts] = []
    for call_tools, call_parts in calls:
        shift_tool, shift_part = len(tools), len(parts)
        tools += call_tools
        parts += [replace(f, carries=tuple(k + shift_part for k in f.carries),
                          devices=tuple(f"{TOOL_REF}{int(d[len(TOOL_REF):]) + shift_tool}" if d.startswith(TOOL_REF) else d
                                        for d in f.devices)) for f in call_parts]
    return tools, parts


def hands() -> Call:
    """Generated grippers and hands of every layout, and a lone frame (no finger chain)."""
    tools = [tool_structure(load_urdf(b.urdf), b.leaves) for b in map(build, range(0, 400, 25))]
    return [*tools, tool_structure(load_urdf(TOY), ["claw_tcp"])], []


def bodies() -> Call:
    """Generated wheeled and legged robots, half of them with their grippers as tools of the same run."""
    return merged([generated_body(make(seed), tools_in_run=seed % 2 == 1) for make in (wheeled, legged) for seed in range(6)])


# each input, and the classes it must get (so that every condition is put to both reasoners)
CASES = {
    "toy": (lambda: merged(toy_run()), {"ParallelGripper"}, {"Wheel", "Arm"}),
    "hands": (hands, {"ParallelGripper", "MultiFingerGripper", "AnthropomorphicHand", "EndEffector"}, set()),
    "bodies": (bodies, {"ParallelGripper"}, {"Wheel", "MobileBase", "Leg", "Arm", "Head", "Torso", None}),
    "boundaries": (boundaries, set(), {"Wheel", "MobileBase", "Leg", "Arm", "Head", "Torso", None}),
    "carried": (carried, set(), {"Arm", "Head", "Leg", "Torso", None}),
    "suspended": (suspended, set(), {"Wheel", "MobileBase", "Arm", None}),
}


@pytest.mark.reasoner
@pytest.mark.parametrize("case", CASES)
def test_the_scripted_reasoner_agrees_with_hermit(case):
    """One HermiT run per case (merged into one, the cases take HermiT twice as long)."""
    make, kinds, body_classes = CASES[case]
    tools, parts = make()
    hermit = classify_together(tools, parts)
    assert scripted_reasoner(tools, parts)[:2] == hermit[:2]
    assert {i.cls for i in hermit[0]} == kinds and set(hermit[1]) == body_classes


@pytest.mark.reasoner
def test_the_scripted_placements_agree_with_hermit():
    classes = tuple(c for kind in TAX.kinds.values() for c in TAX.subclasses_below(kind.cls))
    hermit, seconds = placements(TAX.body_classes, classes)
    assert scripted_placements(TAX.body_classes, classes)[0] == hermit
    assert seconds > 0 and set().union(*hermit.values()) == {"Bumper"}  # the ontology's one ∀isLocatedOn restriction
    assert placements(TAX.body_classes, classes) == (hermit, 0.0)  # asked once per process
