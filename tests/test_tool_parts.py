"""What a tool's structure leaves open for its links' sub-part classes (stages.subparts): a leaf fixed to
a finger is its contact surface, never a finger itself (a finger is jointed), on generated grippers and
hands; a one-jaw gripper (a lone moving jaw against the fixed body it hangs from) is mounted where that
body is bolted, and its jaw is a finger or contact surface like any finger's link; no leaf is a palm."""
from __future__ import annotations

import random

import pytest
from tests.hand_robots import build
from tests.urdf_writer import Writer

from urdfkb.pipeline.reading.ingest import load_urdf
from urdfkb.pipeline.knowledge.ontology import vocabulary
from urdfkb.pipeline.abstraction.stages.attachment import sub_chain
from urdfkb.pipeline.abstraction.stages.grouping import Group
from urdfkb.pipeline.abstraction.oracle import Oracle
from urdfkb.pipeline.abstraction.stages.classification import Typed
from urdfkb.pipeline.abstraction.stages.subparts import _structural_parts, type_subparts
from urdfkb.pipeline.llm.scripted import ScriptedBackend
from urdfkb.pipeline.abstraction.structure import tool_structure

TAX = vocabulary()
TOOLS = TAX.kinds["end_effector"]
SUBPARTS = set(TAX.subclasses_below(TOOLS.subparts))


def allowed(tree, leaves: list[str], mount: str) -> dict[str, set[str]]:
    """Each tool link → the sub-part classes structure leaves offered."""
    group = Group([sub_chain(tree, leaf, mount) for leaf in leaves])
    excluded = _structural_parts(TAX, tree, TOOLS, [group], [tool_structure(tree, leaves)])
    return {link: SUBPARTS - out for link, out in excluded.items()}


@pytest.mark.parametrize("seed", range(200))
def test_a_leaf_fixed_to_a_finger_is_its_contact_surface(seed):
    built = build(seed)
    tree = load_urdf(built.urdf)
    offered = allowed(tree, built.leaves, built.mount)
    for chain in built.chains:
        for link in chain.links:
            fixed_tip = tree.is_leaf(link) and not tree.edge_to(link).movable
            assert offered[link] == ({"ContactSurface"} if fixed_tip else {"Finger", "ContactSurface"}), \
                (built.description, link)


def _arm_end(w: Writer, rng: random.Random, most: int) -> str:
    """The last link of an arm of three to `most` pitching joints up from a bare base frame."""
    link = w.link()
    for _ in range(rng.randint(3, most)):
        child = w.link('<box size="0.05 0.05 0.2"/>')
        w.joint("revolute", link, child, (0.0, 0.0, 0.2), (0.0, 1.0, 0.0))
        link = child
    return link


def one_jaw(seed: int, tcp: bool):
    """An arm whose flange carries a fixed jaw (a box) and, on a revolute joint, a moving jaw; `tcp`: with a
    tool frame fixed on the fixed jaw too (else the moving jaw is the tool's lone leaf)."""
    rng = random.Random(seed)
    w = Writer(rng)
    link = _arm_end(w, rng, 6)
    stator = w.link('<box size="0.04 0.06 0.1"/>')
    w.joint("fixed", link, stator, (0.0, 0.0, 0.05))
    jaw = w.link('<box size="0.01 0.02 0.08"/>')
    w.joint("revolute", stator, jaw, (0.0, 0.02, 0.05), (1.0, 0.0, 0.0), (-0.2, 1.0))
    leaves = [jaw]
    if tcp:
        leaves.append(w.link())
        w.joint("fixed", stator, leaves[-1], (0.0, 0.0, 0.12))
    return load_urdf(w.urdf()), link, stator, jaw, leaves


@pytest.mark.parametrize("tcp", [False, True])
@pytest.mark.parametrize("seed", range(20))
def test_a_one_jaw_gripper_is_mounted_above_its_fixed_jaw_and_its_jaw_is_a_finger(seed, tcp):
    tree, flange, stator, jaw, leaves = one_jaw(seed, tcp)
    structure = tool_structure(tree, leaves)
    assert structure.fingers == ()  # one moving chain opposes nothing: no finger chain
    assert structure.mount == flange  # the body a lone moving jaw closes against is the tool's
    offered = allowed(tree, leaves, flange)
    assert offered[jaw] == {"Finger", "ContactSurface"}
    assert "Finger" not in offered[stator] and "Palm" in offered[stator]  # the jaw hangs from it
    assert not tcp or not {"Finger", "Palm"} & offered[leaves[-1]]


def fixed_jaw_gripper(seed: int, prismatic: bool):
    """An arm's last link carrying, as a hobby servo gripper does, a moving jaw and a fixed jaw drawn with the same
    mesh (the fixed one turned about), and a bare tool frame on a revolute joint of its own (a virtual wrist roll)."""
    rng = random.Random(seed)
    w = Writer(rng)
    link = _arm_end(w, rng, 5)
    finger = '<mesh filename="package://hobby_gripper/meshes/%s.stl"/>' % rng.choice(["jaw", "finger", "claw_half"])
    moving, fixed, frame = w.link(finger), w.link(finger), w.link()
    w.joint("prismatic" if prismatic else "revolute", link, moving, (0.0, 0.0, 0.07), (0.0, 1.0, 0.0), (0.002, 0.03))
    w.joint("fixed", link, fixed, (0.0, -0.016, 0.07), rpy=(3.14159, 0.0, 0.0))
    w.joint("revolute", link, frame, (0.0, 0.0, 0.11), (1.0, 0.0, 0.0), (-3.14, 3.14))
    return load_urdf(w.urdf()), link, moving, fixed, frame


@pytest.mark.parametrize("prismatic", [False, True])
@pytest.mark.parametrize("seed", range(10))
def test_a_fixed_jaw_shaped_as_the_moving_one_is_a_finger_and_a_bare_frame_no_jaw(seed, prismatic):
    """The fixed jaw is offered a finger's classes as the moving jaw is; the bare frame turning on its own joint
    has nothing to close with: no finger, and no palm (a leaf)."""
    tree, last, moving, fixed, frame = fixed_jaw_gripper(seed, prismatic)
    leaves = [moving, fixed, frame]
    offered = allowed(tree, leaves, tool_structure(tree, leaves).mount)
    assert offered[moving] == offered[fixed] == {"Finger", "ContactSurface"}
    assert not {"Finger", "Palm"} & offered[frame] and "ToolCenterPoint" in offered[frame]


def test_a_lone_tip_takes_its_body_into_the_tool_and_no_leaf_is_a_palm():
    """A rigid tool (a ball with a tip frame, no finger) is mounted where the ball is bolted; its body may be
    a palm, its leaf may not (nothing extends from it)."""
    w = Writer(random.Random(1))
    flange, ball, tip = w.link('<box size="0.05 0.05 0.1"/>'), w.link('<sphere radius="0.05"/>'), w.link()
    w.joint("fixed", flange, ball, (0.0, 0.0, 0.1))
    w.joint("fixed", ball, tip, (0.0, 0.0, 0.05))
    tree = load_urdf(w.urdf())
    assert tool_structure(tree, [tip]).mount == flange  # the ball its tip hangs from belongs to the tool
    offered = allowed(tree, [tip], flange)
    assert "Palm" in offered[ball] and "Palm" not in offered[tip] and "ToolCenterPoint" in offered[tip]


def test_a_lone_leaf_on_a_body_that_carries_an_arm_stays_on_that_body():
    """A frame on a torso from which an arm moves: the torso is no part of a tool made of that frame."""
    w = Writer(random.Random(2))
    base, torso, frame = w.link('<box size="0.4 0.4 0.2"/>'), w.link('<box size="0.3 0.3 0.5"/>'), w.link()
    w.joint("fixed", base, torso, (0.0, 0.0, 0.3))
    w.joint("fixed", torso, frame, (0.1, 0.0, 0.2))
    link = torso
    for _ in range(4):
        child = w.link('<box size="0.05 0.05 0.2"/>')
        w.joint("revolute", link, child, (0.0, 0.0, 0.2), (0.0, 1.0, 0.0))
        link = child
    assert tool_structure(load_urdf(w.urdf()), [frame]).mount == torso


def test_a_spinning_spindle_of_a_fingerless_tool_is_no_jaw():
    """A drill on a flange: its spindle spins (a continuous joint), so it is offered no finger's classes."""
    w = Writer(random.Random(3))
    flange, body, spindle, bit = (w.link('<box size="0.05 0.05 0.1"/>') for _ in range(4))
    tcp = w.link()
    w.joint("fixed", flange, body, (0.0, 0.0, 0.05))
    w.joint("continuous", body, spindle, (0.0, 0.0, 0.1))
    w.joint("fixed", spindle, bit, (0.0, 0.0, 0.05))
    w.joint("fixed", body, tcp, (0.0, 0.0, 0.2))
    tree = load_urdf(w.urdf())
    assert tool_structure(tree, [bit, tcp]).mount == flange
    offered = allowed(tree, [bit, tcp], flange)
    assert "Finger" not in offered[spindle] and "ToolHousing" in offered[spindle]


def test_a_drawn_link_of_a_tool_is_no_tool_frame_whatever_the_model_says():
    """The small model calls a gripper's drawn body (its palm) and a bar of its linkage "tool frame" (a class the
    ontology marks core:frameOnly): a drawn link is asked without it and gets the model's next answer; the bare
    frame at the tool's point still gets it."""
    tree, flange, stator, jaw, leaves = one_jaw(3, tcp=True)
    tcp = leaves[1]
    group = Group([sub_chain(tree, leaf, flange) for leaf in leaves])
    offered: dict[str, list[str]] = {}

    def tool_frame_first(q):
        offered[q.key] = q.options
        return {o: (0.6 if o == TAX.answer("ToolCenterPoint") else 0.4 / len(q.options)) for o in q.options}
    parts = type_subparts(Oracle(ScriptedBackend(tool_frame_first)), TAX, tree, TOOLS, [group],
                          [Typed("ParallelGripper", 0.9)], [tool_structure(tree, leaves)])
    assert parts[tcp].cls == "ToolCenterPoint"
    asked_stator = [options for key, options in offered.items() if key.startswith(f"part:{stator}@")]
    assert parts[stator].cls != "ToolCenterPoint" and asked_stator
    assert not any(TAX.answer("ToolCenterPoint") in options for options in asked_stator)
    assert parts[jaw].cls != "ToolCenterPoint"
