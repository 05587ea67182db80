"""End-effectors from structure: finger chains, the ontology's gripper kinds (HermiT, or the scripted reasoner
in the pipeline's runs), extent and mount.

tests/data/tool_rack.urdf is an invented robot with three tools (and a clamp half-way up one arm): a vise (two sliding jaws, one
mimicking the other) with a cuff camera beside it on the flange, a three-prong gripper driven by one
motor joint, and a hand of four digits and an opposing digit hung straight on its wrist link.
"""
from __future__ import annotations

import math
import random
from pathlib import Path

import owlready2
import pytest
import rdflib

from tests.scripted_reasoner import scripted_reasoner
from tests.urdf_writer import Writer
from urdfkb.pipeline.abstraction.abstractor import Abstractor
from urdfkb.pipeline.abstraction.components import Abstraction
from urdfkb.pipeline.knowledge.export import robot_graph
from urdfkb.pipeline.reading.ingest import load_urdf
from urdfkb.pipeline.llm.base import Question
from urdfkb.pipeline.llm.scripted import ScriptedBackend
from urdfkb.pipeline.knowledge.namespaces import CORE_IRI
from urdfkb.pipeline.knowledge.ontology import vocabulary
from urdfkb.pipeline.abstraction.oracle import Oracle
from urdfkb.pipeline.knowledge.population import build_robot
from urdfkb.pipeline.abstraction.prompts import NONE
from urdfkb.pipeline.knowledge.reasoning import classify
from urdfkb.pipeline.knowledge.shacl import validate
from urdfkb.pipeline.abstraction.stages.grouping import Group
from urdfkb.pipeline.abstraction.stages.attachment import sub_chain
from urdfkb.pipeline.abstraction.stages.tools import settle
from urdfkb.pipeline.abstraction.hands import rolling
from urdfkb.pipeline.abstraction.frames import loop_closures
from urdfkb.pipeline.abstraction.structure import mount_of, tool_structure

RACK = Path(__file__).parent / "data" / "tool_rack.urdf"
TAX = vocabulary()
VISE = ["vise_jaw_port", "vise_jaw_starboard", "vise_grip_point"]
TRIDENT = ["trident_motor", "trident_prong0_tip", "trident_prong1_tip", "trident_prong2_tip"]
MITT = ["mitt_drive", *(f"mitt_digit{k}_end" for k in range(4)), "mitt_opposer_end"]


@pytest.fixture(scope="module")
def rack():
    return load_urdf(RACK)


def test_ingestion_reads_axis_limits_mimic_and_transmissions(rack):
    port, starboard = rack.parent_edge("vise_jaw_port"), rack.parent_edge("vise_jaw_starboard")
    assert starboard.mimic == "vise_port_slide" and starboard.mimic_multiplier == 1.0 and port.mimic is None
    assert port.axis == (0.0, -1.0, 0.0) and port.limits == (0.0, 0.03)
    assert rack.parent_edge("trident_motor").actuated and not port.actuated
    assert rack.parent_edge("vise_grip_point").axis == (1.0, 0.0, 0.0) and rack.parent_edge("vise_grip_point").limits is None


def test_vise_has_two_opposing_sliding_jaws_and_is_bolted_to_the_flange(rack):
    vise = tool_structure(rack, VISE)
    assert (vise.fork, vise.mount) == ("vise_body", "left_flange")
    port, starboard = vise.fingers
    assert {port.motion, starboard.motion} == {"prismatic"}
    assert port.opposes == ("vise_jaw_starboard",) and starboard.mimics == "vise_jaw_port"


def test_prongs_all_oppose_and_the_motor_is_a_mechanism(rack):
    trident = tool_structure(rack, TRIDENT)
    assert trident.mechanisms == ("trident_motor",)  # its leaf sits on its own axis: nothing closes
    assert [len(f.opposes) for f in trident.fingers] == [2, 2, 2]
    assert all(f.moves_with == () for f in trident.fingers)


def test_hand_on_the_wrist_is_mounted_on_the_wrist_and_its_digits_move_together(rack):
    mitt = tool_structure(rack, MITT)
    assert mitt.fork == mitt.mount == "mid_wrist"  # fingers hung straight on the arm's last moving link
    opposer = next(f for f in mitt.fingers if f.name == "mitt_opposer_base")
    assert len(opposer.opposes) == 4
    assert all(len(f.moves_with) == 3 for f in mitt.fingers if f is not opposer)
    assert mount_of(rack, "vise_grip_point") == "vise_body"  # a lone leaf on a body its jaws move from: on it


@pytest.mark.reasoner
def test_the_reasoner_classifies_every_tool_in_one_run(rack):
    tools = [tool_structure(rack, leaves) for leaves in (VISE, TRIDENT, MITT, ["vise_grip_point"])]
    inferred, seconds = classify(tools)
    assert [i.cls for i in inferred] == ["ParallelGripper", "MultiFingerGripper", "AnthropomorphicHand", "EndEffector"]
    assert inferred[2].thumbs == ("mitt_opposer_base",) and inferred[1].thumbs == ()  # prongs oppose, none a thumb
    assert not inferred[3].settled and seconds > 0


def test_settle_remounts_splits_arms_and_keeps_every_finger(rack):
    notes: list[str] = []
    too_high = Group([sub_chain(rack, leaf, "left_seg1") for leaf in VISE])  # the model mounted it on the shoulder
    thumbless = Group([sub_chain(rack, leaf, "mid_seg3") for leaf in MITT[:3]])  # thumb and two digits left out
    both_arms = Group([sub_chain(rack, leaf, "torso") for leaf in TRIDENT[:2] + ["mitt_drive"]])
    settled = settle(rack, [too_high, thumbless, both_arms], lambda leaf: False, notes.append)
    by_mount = {group_root_of(g): set(g.leaves) for g, _ in settled}
    assert by_mount == {"left_flange": set(VISE), "right_flange": set(TRIDENT), "mid_wrist": set(MITT)}
    assert any(n.startswith("split") for n in notes)


def test_a_group_not_at_the_end_of_an_arm_is_no_tool(rack):
    notes: list[str] = []
    clamp = Group([sub_chain(rack, "left_shoulder_clamp", "left_seg1")])  # one joint from the torso
    vise = Group([sub_chain(rack, leaf, "left_flange") for leaf in VISE])
    settled = settle(rack, [clamp, vise], lambda leaf: False, notes.append)
    assert [set(g.leaves) for g, _ in settled] == [set(VISE)]
    assert any(n.startswith("no tool: ['left_shoulder_clamp']") for n in notes)


def test_a_group_on_a_link_that_carries_the_rest_of_the_arm_is_no_tool(shared):
    """Sawyer's extra collision volume on its second arm link: five more arm joints hang beside it."""
    sawyer = load_urdf(shared / "urdf" / "sawyer.urdf")
    notes: list[str] = []
    assert settle(sawyer, [Group([sub_chain(sawyer, "right_l2_2", "right_l2")])], lambda leaf: False, notes.append) == []
    assert notes == ["no tool: ['right_l2_2'] mounted on right_l2, which is not the end of an arm"]


def group_root_of(group):
    (root,) = {c.root for c in group.chains}
    return root


KIND = {leaf: "end effector" for leaf in VISE + TRIDENT + MITT} | {"cuff_cam_optical": "sensor"}


OFFERED: dict[str, tuple[str, ...]] = {}


def perfect(q: Question) -> str | dict:
    OFFERED[q.key] = q.options
    stage, _, subject = q.key.partition(":")
    subject = subject.partition("@")[0]
    if stage == "check":
        return "sensor"
    if stage == "identify":
        return KIND.get(subject, NONE)
    if stage == "root":
        return q.options[-1]  # as high as offered: structure must bring it down to the flange
    if stage == "device":
        return q.options[-1]
    if stage == "post" and subject in KIND and KIND[subject] == "end effector":
        raise AssertionError(f"the model was asked the kind of a tool whose structure settles it: {q.key}")
    return q.options[0]


def test_pipeline_takes_kinds_from_the_reasoner_and_keeps_the_camera_apart(rack):
    abstractor = Abstractor(Oracle(ScriptedBackend(perfect)), TAX, reasoner=scripted_reasoner)
    found = abstractor.run(rack)
    comps = found.components
    tools = {c.cls: c for c in comps if c.kind == "end_effector"}
    assert set(tools) == {"ParallelGripper", "MultiFingerGripper", "AnthropomorphicHand"}
    assert tools["ParallelGripper"].root == "left_flange" and tools["AnthropomorphicHand"].root == "mid_wrist"
    assert "cuff_cam_optical" not in {link for c in tools.values() for link in c.links}
    hand = {s.link: s.cls for s in tools["AnthropomorphicHand"].subcomponents}
    assert hand["mitt_opposer_end"] == "ContactSurface"  # a leaf fixed to a finger: its tip, not a finger,
    assert not any(key.startswith("part:mitt_opposer_end@") for key in OFFERED)  # and nothing else to ask
    assert hand["mitt_drive"] != "Finger"  # the motor joint's link is no finger
    assert "palm" in OFFERED["part:vise_body@EndEffectorSubpart"]  # the jaws hang from it
    assert not {"palm", "finger"} & set(OFFERED["part:vise_grip_point@EndEffectorSubpart"])

    onto = build_robot(owlready2.World(), rack, "tool_rack", Abstraction(tuple(comps), body=tuple(found.body)))
    graph = robot_graph(onto)
    assert validate(graph)[0]
    core = rdflib.Namespace(CORE_IRI)
    thumbs = list(graph.subjects(rdflib.RDF.type, core.ThumbChain))
    assert len(thumbs) == 1
    opposed = set(graph.objects(thumbs[0], core.opposes)) | set(graph.subjects(core.opposes, thumbs[0]))
    assert len(opposed) == 4  # opposes is symmetric: each pair is written once
    assert (None, core.isMimicOf, None) in graph  # the starboard slide follows the port slide


def test_a_leaf_moving_on_a_mimic_joint_is_no_sensor(rack):
    def jaw_as_sensor(q: Question) -> str | dict:
        if q.key == "identify:vise_jaw_starboard":
            return "sensor"  # the model's mistake: the jaw that follows the other is taken for a sensor
        return perfect(q)
    abstractor = Abstractor(Oracle(ScriptedBackend(jaw_as_sensor)), TAX, reasoner=scripted_reasoner)
    found = abstractor.run(rack)
    comps = found.components
    vise = next(c for c in comps if c.kind == "end_effector" and c.root == "left_flange")
    assert vise.cls == "ParallelGripper" and "vise_jaw_starboard" in vise.links
    assert not any(c.kind == "sensor" and "vise_jaw_starboard" in c.links for c in comps)
    assert "vise_jaw_starboard" in found.hand_mounts  # a finger by structure: never asked, never a sensor



def test_without_a_reasoner_the_model_is_asked_the_kinds(rack, monkeypatch):
    def no_java(*args, **kwargs):
        raise owlready2.OwlReadyJavaError("java not found")
    monkeypatch.setattr(owlready2, "sync_reasoner_hermit", no_java)
    inferred, _ = classify([tool_structure(rack, VISE), tool_structure(rack, MITT)])
    assert [i.settled for i in inferred] == [False, False]


def _arm_with(end: str) -> tuple[bytes, set[str]]:
    """A 3-joint arm whose flange carries `end` (a rigid ball with a tip frame, or a one-jaw gripper beside a
    tip frame), and the tool's leaves."""
    w = Writer(random.Random(7))
    link = w.link('<box size="0.05 0.05 0.2"/>')
    for _ in range(3):
        child = w.link('<box size="0.05 0.05 0.2"/>')
        w.joint("revolute", link, child, (0.0, 0.0, 0.2), (0.0, 1.0, 0.0), (-2.0, 2.0))
        link = child
    tip = w.link()
    if end == "ball":
        ball = w.link('<sphere radius="0.05"/>')
        w.joint("fixed", link, ball, (0.0, 0.0, 0.1))
        w.joint("fixed", ball, tip, (0.0, 0.0, 0.07))
        return w.urdf(), {tip}
    jaw = w.link('<box size="0.01 0.02 0.06"/>')
    w.joint("revolute", link, jaw, (0.02, 0.0, 0.1), (0.0, 1.0, 0.0), (0.0, 0.8))
    w.joint("fixed", link, tip, (0.0, 0.0, 0.15))
    return w.urdf(), {tip, jaw}


@pytest.mark.parametrize("end,offered", [("ball", True), ("jaw", False)])
def test_a_tool_in_which_nothing_moves_may_stay_a_plain_end_effector(end, offered):
    """Below EndEffector the ontology has grippers and hands only; a rigid ball on a flange is neither, and the
    model answering "rigid tool" keeps it a plain EndEffector. A one-jaw gripper moves: it is not offered that."""
    asked = []

    urdf, tool_leaves = _arm_with(end)

    def rule(q: Question):
        if q.key.startswith("identify:"):
            return "end effector" if q.key.split(":", 1)[1] in tool_leaves else NONE
        if q.key.startswith("post:"):
            asked.append(q.options)
            return "rigid tool" if "rigid tool" in q.options else "gripper"
        return q.options[0]
    comps = Abstractor(Oracle(ScriptedBackend(rule)), TAX, reasoner=scripted_reasoner).run(load_urdf(urdf)).components
    (tool,) = [c for c in comps if c.kind == "end_effector"]
    assert asked and ("rigid tool" in asked[0]) is offered
    assert (tool.cls == "EndEffector") is offered


def test_alike_tools_are_asked_their_kind_once_the_first_standing_for_both():
    """Two mirrored three-joint arms on a torso, each ending in a rigid ball with a tip frame: the kind of the left
    one is asked, and the right one takes it, where a model split on a near tie would give each its own."""
    w = Writer(random.Random(8))
    torso = w.link('<box size="0.2 0.4 0.5"/>')
    tips = []
    for y in (0.2, -0.2):
        link = w.link('<box size="0.05 0.05 0.05"/>')
        w.joint("fixed", torso, link, (0.0, y, 0.2))
        for _ in range(3):
            child = w.link('<box size="0.05 0.05 0.2"/>')
            w.joint("revolute", link, child, (0.0, 0.0, 0.2), (0.0, 1.0, 0.0), (-2.0, 2.0))
            link = child
        ball, tip = w.link('<sphere radius="0.05"/>'), w.link()
        w.joint("fixed", link, ball, (0.0, 0.0, 0.1))
        w.joint("fixed", ball, tip, (0.0, 0.0, 0.07))
        tips.append(tip)
    asked = []

    def rule(q: Question):
        if q.key.startswith("identify:"):
            return "end effector" if q.key.split(":", 1)[1] in tips else NONE
        if q.key.startswith("post:") and q.key.endswith("@EndEffector"):
            asked.append(q.key)
            return "hand" if len(asked) == 1 else "gripper"
        return q.options[0]
    comps = Abstractor(Oracle(ScriptedBackend(rule)), TAX, reasoner=scripted_reasoner).run(load_urdf(w.urdf())).components
    tools = [c for c in comps if c.kind == "end_effector"]
    assert asked == [f"post:{tips[0]}@EndEffector"]
    assert len(tools) == 2 and tools[0].cls == tools[1].cls and TAX.is_a(tools[0].cls, "Hand")


def test_a_fixed_jaw_the_model_hardly_calls_a_sensor_stays_the_grippers():
    """A one-jaw gripper at an arm's end: a jaw turning on a servo and a fixed jaw beside it. The model takes the fixed
    jaw for a sensor it hardly believes in (under the floor: the screen holds it, never written); it stays in the tree
    the tool pass sees, so the gripper keeps its fixed jaw (on the code before: the sensor pass took it out)."""
    w = Writer(random.Random(12))
    link = w.arm(w.link('<box size="0.3 0.3 0.1"/>'))
    servo = w.link('<box size="0.04 0.03 0.05"/>')
    w.joint("fixed", link, servo, (0.0, 0.0, 0.05))
    moving = w.link('<box size="0.01 0.02 0.06"/>', centre=(0.0, 0.0, 0.03))
    w.joint("revolute", servo, moving, (0.015, 0.0, 0.03), (0.0, 1.0, 0.0), (-0.8, 0.5))
    fixed = w.link('<box size="0.01 0.02 0.06"/>', centre=(0.0, 0.0, 0.03))
    w.joint("fixed", servo, fixed, (-0.015, 0.0, 0.03))
    doubt = {"sensor": 0.55, "end effector": 0.15, "body part": 0.15, "none": 0.15}

    def rule(q: Question):
        stage, _, subject = q.key.partition(":")
        if stage == "identify":
            return doubt if subject == fixed else "end effector" if subject == moving else NONE
        if stage == "pre":  # the sensor's kind: split too
            return {option: 0.3 if i == 0 else 0.1 for i, option in enumerate(q.options)}
        return q.options[0]
    comps = Abstractor(Oracle(ScriptedBackend(rule)), TAX, reasoner=scripted_reasoner).run(load_urdf(w.urdf())).components
    (tool,) = [c for c in comps if c.kind == "end_effector"]
    held = [c for c in comps if c.kind == "sensor"]
    assert held and all(c.confidence < 0.2 for c in held)
    assert {moving, fixed} <= set(tool.links)


def test_a_rigid_body_swung_by_joints_that_meet_at_one_point_is_the_limbs_segment_not_a_tool():
    """An upper body with a short arm (shoulder pitch and roll meeting at one point, the forearm fixed 0.15 m out
    from them) and a six-joint arm ending in a rigid tool 0.05 m out from its flange, names meaningless: the
    forearm reaches farther out than the limb above it is long, so it is the limb's own segment, no tool; the
    rigid tool is small beside its arm and stays one."""
    w = Writer(random.Random(21))
    torso = w.link('<box size="0.3 0.4 0.6"/>')
    shoulder, upper, fore = w.link(), w.link('<box size="0.05 0.05 0.2"/>'), w.link('<box size="0.05 0.05 0.2"/>')
    w.joint("revolute", torso, shoulder, (0.0, -0.2, 0.45), (0.0, 1.0, 0.0))
    w.joint("revolute", shoulder, upper, (0.0, 0.0, 0.0), (1.0, 0.0, 0.0))
    w.joint("fixed", upper, fore, (0.0, -0.15, 0.0))
    link = torso
    for i, z in enumerate((0.2, 0.1, 0.3, 0.1, 0.25, 0.1)):
        child = w.link('<box size="0.05 0.05 0.2"/>')
        w.joint("revolute", link, child, (0.0, 0.2 if i == 0 else 0.0, z), (0.0, 0.0, 1.0) if i % 3 == 0 else (0.0, 1.0, 0.0))
        link = child
    tip = w.link('<cylinder radius="0.02" length="0.05"/>')
    w.joint("fixed", link, tip, (0.0, 0.0, 0.05))
    tree = load_urdf(w.urdf())
    notes: list[str] = []
    groups = [Group([sub_chain(tree, fore, upper)]), Group([sub_chain(tree, tip, link)])]
    settled = settle(tree, groups, lambda leaf: True, notes.append)
    assert [g.leaves for g, _ in settled] == [[tip]]
    assert notes[0] == f"no tool: ['{fore}'] reach out from {upper} farther than the limb carrying it is long (its segment)"


@pytest.mark.parametrize("seed", [31, 32])
def test_jaws_written_as_one_link_each_close_where_their_mass_is(seed):
    """Two jaws, each one link whose frame lies on its hinge (one following the other by <mimic>, about the opposite
    axis), their centres of mass 0.03 m out along them: at their frames nothing moves, so the jaws are read where
    their mass is and close on each other, two opposing fingers (on the code before: two mechanisms and no finger)."""
    w = Writer(random.Random(seed))
    link = w.arm(w.link('<box size="0.3 0.3 0.1"/>'))
    jaw_a = w.link('<box size="0.01 0.01 0.06"/>', centre=(0.0, -0.005, 0.03))
    jaw_b = w.link('<box size="0.01 0.01 0.06"/>', centre=(0.0, 0.005, 0.03))
    drive = w.joint("revolute", link, jaw_a, (0.0, 0.02, 0.05), (1.0, 0.0, 0.0), (0.0, 1.0))
    w.joint("revolute", link, jaw_b, (0.0, -0.02, 0.05), (-1.0, 0.0, 0.0), (0.0, 1.0), mimic=drive)
    tree = load_urdf(w.urdf())
    structure = tool_structure(tree, [jaw_a, jaw_b])
    assert {(f.name, f.opposes) for f in structure.fingers} == {(jaw_a, (jaw_b,)), (jaw_b, (jaw_a,))}
    assert structure.mechanisms == ()


def test_a_rigid_tool_on_a_gantrys_sliding_joints_stays_a_tool():
    """A gantry's three sliding joints carry a rigid spindle 0.12 m below the last carriage: their travel is no
    offset, so the tool is no limb segment."""
    w = Writer(random.Random(22))
    link = w.link('<box size="1.0 1.0 0.1"/>')
    for axis in ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)):
        child = w.link('<box size="0.1 0.1 0.1"/>')
        w.joint("prismatic", link, child, (0.0, 0.0, 0.0), axis, (0.0, 0.5))
        link = child
    spindle = w.link('<cylinder radius="0.02" length="0.1"/>')
    w.joint("fixed", link, spindle, (0.0, 0.0, -0.12))
    tree = load_urdf(w.urdf())
    settled = settle(tree, [Group([sub_chain(tree, spindle, link)])], lambda leaf: True, lambda _note: None)
    assert [g.leaves for g, _ in settled] == [[spindle]]


@pytest.mark.parametrize("end", ["flange", "jaw"])
def test_a_wrist_roll_turning_a_flange_is_the_arms_and_the_tool_is_what_it_carries(end):
    """A six-joint arm whose last link carries a bare wrist frame and one more joint: a roll (range past a turn,
    about the line the arm runs along) turning a flange drawn on its axis, or a jaw hinged across the line, its tip
    frame swinging 6 cm out. The model groups the wrist frame with the flange or the jaw tip. The roll turns the flange
    in place: it is the arm's last joint, the tool is the flange alone, mounted on the roll's link. The jaw swings its
    tip: it stays one tool with the frame beside it."""
    w = Writer(random.Random(9))
    link = w.arm(w.link('<box size="0.3 0.3 0.1"/>'))
    wrist = w.link()
    w.joint("fixed", link, wrist, (0.0, 0.0, 0.1))
    moving = w.link('<cylinder radius="0.04" length="0.05"/>')
    if end == "flange":
        w.joint("revolute", link, moving, (0.0, 0.0, 0.1), (0.0, 0.0, 1.0), (-4.7, 4.7))
        tip = w.link('<cylinder radius="0.035" length="0.03"/>')
        w.joint("fixed", moving, tip, (0.0, 0.0, 0.025))
    else:
        w.joint("revolute", link, moving, (0.02, 0.0, 0.1), (0.0, 1.0, 0.0), (0.0, 0.8))
        tip = w.link()
        w.joint("fixed", moving, tip, (0.0, 0.0, 0.06))
    tree = load_urdf(w.urdf())
    notes: list[str] = []
    settled = settle(tree, [Group([sub_chain(tree, wrist, link), sub_chain(tree, tip, link)])], lambda leaf: True,
                     notes.append)
    expected = {moving: [tip]} if end == "flange" else {link: [wrist, tip]}
    assert {structure.mount: g.leaves for g, structure in settled} == expected
    assert (f"['{wrist}'] hang before ['{tip}']'s roll, the arm's last joint" in notes) is (end == "flange")


@pytest.mark.parametrize("apart, palm", [(0.0, False), (0.04, False), (0.0, True)])
def test_chains_hung_at_one_point_of_the_arms_end_are_one_tool(apart, palm):
    """A four-joint arm whose last link carries, at one point, a bare tool frame with a one-link finger turning
    below it and a two-joint finger (its hand written as joints beside the tool frame, as PAL's are); the model
    mounts each finger on the link just above it, so they were two tools, the second on a link of the first's
    arm. Hung at one point, they are one tool on the arm's last link; a chain hung 4 cm away stays a tool of its
    own, and so does one beside a tool's body (a palm: two tools on one flange)."""
    w = Writer(random.Random(5))
    link = w.link('<box size="0.05 0.05 0.2"/>')
    for i in range(4):
        child = w.link('<box size="0.05 0.05 0.2"/>')
        w.joint("revolute", link, child, (0.0, 0.0, 0.2 if i else 0.5), (0.0, 1.0, 0.0) if i % 2 else (0.0, 0.0, 1.0))
        link = child
    frame, finger = w.link('<box size="0.08 0.08 0.04"/>' if palm else ""), w.link('<sphere radius="0.001"/>')
    w.joint("fixed", link, frame, (0.0, 0.0, 0.25))
    w.joint("revolute", frame, finger, axis=(0.0, 1.0, 0.0), limits=(0.0, 1.3))
    knuckle, tip = w.link('<box size="0.02 0.02 0.05"/>'), w.link('<box size="0.02 0.02 0.05"/>')
    w.joint("revolute", link, knuckle, (apart, 0.0, 0.25), (0.0, 1.0, 0.0), (0.0, 1.3))
    w.joint("revolute", knuckle, tip, (0.0, 0.0, 0.05), (0.0, 1.0, 0.0), (0.0, 1.3))
    tree = load_urdf(w.urdf())
    groups = [Group([sub_chain(tree, finger, frame)]), Group([sub_chain(tree, tip, knuckle)])]
    settled = settle(tree, groups, lambda leaf: True, lambda note: None)
    by_mount = {structure.mount: set(g.leaves) for g, structure in settled}
    assert by_mount == ({link: {finger}, knuckle: {tip}} if apart or palm else {link: {finger, tip}})


@pytest.mark.parametrize("seed", [41, 42])
def test_a_thumb_written_as_one_link_closes_on_the_fingers_where_its_mass_is(seed):
    """Two fingers of two links side by side curl the same way; a thumb across from them is one link whose frame
    lies on its hinge, its centre of mass 0.03 m out along it: at its frame nothing moves, so it is read where its
    mass is and closes on both fingers (on the code before: no finger at all, the hand a plain end effector)."""
    w = Writer(random.Random(seed))
    link = w.arm(w.link('<box size="0.3 0.3 0.1"/>'))
    fingers = []
    for x in (0.015, -0.015):
        proximal, distal, tip = w.link('<box size="0.01 0.01 0.03"/>'), w.link('<box size="0.01 0.01 0.03"/>'), w.link()
        w.joint("revolute", link, proximal, (x, 0.01, 0.05), (1.0, 0.0, 0.0), (0.0, 1.0))
        w.joint("revolute", proximal, distal, (0.0, 0.0, 0.03), (1.0, 0.0, 0.0), (0.0, 1.0))
        w.joint("fixed", distal, tip, (0.0, 0.0, 0.03))
        fingers.append((proximal, tip))
    thumb = w.link('<box size="0.01 0.01 0.06"/>', centre=(0.0, 0.0, 0.03))
    w.joint("revolute", link, thumb, (0.0, -0.03, 0.05), (-1.0, 0.0, 0.0), (0.0, 1.0))
    tree = load_urdf(w.urdf())
    structure = tool_structure(tree, [thumb, *(tip for _, tip in fingers)])
    opposes = {f.name: set(f.opposes) for f in structure.fingers}
    assert opposes[thumb] == {proximal for proximal, _ in fingers}
    assert all(opposes[proximal] == {thumb} for proximal, _ in fingers)


def test_a_finger_curling_beside_a_finger_the_thumb_closes_on_is_a_finger_too():
    """A thumb closes on the index finger; a ring finger further along the palm curls beside the index (its tip
    moving within 60 degrees of the index's) but, splayed, not towards the thumb: it is a finger moving with the
    index, not a mechanism (a humanoid's left and right hands, mirror images, counted three and four fingers and were
    typed two classes)."""
    w = Writer(random.Random(5))
    palm = w.link('<box size="0.12 0.04 0.08"/>')
    tips = {}

    def finger(at, axis) -> str:
        first = w.link('<box size="0.01 0.01 0.03"/>')
        w.joint("revolute", palm, first, at, axis, (0.0, 1.5))
        parent = w.link('<box size="0.01 0.01 0.03"/>')
        w.joint("revolute", first, parent, (0.0, 0.0, 0.03), axis, (0.0, 1.5))
        tips[first] = w.link()
        w.joint("fixed", parent, tips[first], (0.0, 0.0, 0.03))
        return first
    thumb, index, ring = finger((0.0, -0.05, 0.0), (-1.0, 0.0, 0.0)), finger((0.0, 0.0, 0.02), (1.0, 0.0, 0.0)), \
        finger((0.08, 0.0, 0.02), (0.8, 0.6, 0.0))
    structure = tool_structure(load_urdf(w.urdf()), list(tips.values()))
    fingers = {f.name: f for f in structure.fingers}
    assert set(fingers) == {thumb, index, ring} and structure.mechanisms == ()
    assert fingers[ring].opposes == () and fingers[ring].moves_with == (index,)


@pytest.mark.reasoner
@pytest.mark.parametrize("seed", [51, 52])
def test_fingers_of_one_link_following_another_by_mimic_curl_beside_it_where_their_mass_is(seed):
    """A hand of five fingers: a thumb closes on an index and a middle finger, each with a tip frame beyond it; a ring and a
    little finger are one link each, their frames on their hinges and their centres of mass 0.03 m out along them,
    following the middle finger's joint by <mimic> (a prosthetic hand's coupled fingers). At their frames nothing
    moves, so they are read where their mass is: two fingers curling with the others (on the code before: two
    mechanisms, three fingers and a multi-finger gripper), and the hand an anthropomorphic hand."""
    w = Writer(random.Random(seed))
    palm = w.arm(w.link('<box size="0.08 0.03 0.1"/>'))
    tips, drives = {}, {}
    for name, x in (("index", 0.03), ("middle", 0.01)):
        proximal, distal, tip = w.link('<box size="0.01 0.01 0.03"/>'), w.link('<box size="0.01 0.01 0.03"/>'), w.link()
        drives[name] = w.joint("revolute", palm, proximal, (x, 0.01, 0.05), (1.0, 0.0, 0.0), (0.0, 1.4))
        w.joint("fixed", proximal, distal, (0.0, 0.0, 0.03))
        w.joint("fixed", distal, tip, (0.0, 0.0, 0.03))
        tips[proximal] = tip
    coupled = []
    for x in (-0.01, -0.03):
        finger = w.link('<box size="0.01 0.01 0.06"/>', centre=(0.0, 0.0, 0.03))
        w.joint("revolute", palm, finger, (x, 0.01, 0.05), (1.0, 0.0, 0.0), (0.0, 1.4), mimic=drives["middle"])
        tips[finger] = finger
        coupled.append(finger)
    thumb, thumb_tip = w.link('<box size="0.01 0.01 0.06"/>'), w.link()
    w.joint("revolute", palm, thumb, (0.02, -0.03, 0.03), (-1.0, 0.0, 0.0), (0.0, 1.1))
    w.joint("fixed", thumb, thumb_tip, (0.0, 0.0, 0.06))
    tips[thumb] = thumb_tip
    structure = tool_structure(load_urdf(w.urdf()), list(tips.values()))
    fingers = {f.name: f for f in structure.fingers}
    assert set(fingers) == set(tips) and structure.mechanisms == ()
    assert all(set(fingers[f].moves_with) == set(tips) - {f, thumb} for f in coupled)
    inferred, _ = classify([structure])
    assert inferred[0].cls == "AnthropomorphicHand" and inferred[0].thumbs == (thumb,)


def _parallel_arm_with_open_loop_jaws(seed: int) -> tuple[bytes, str, list[str]]:
    """A small parallel arm on a base: a shoulder motor and a linkage motor beside it, the elbow and the bracket
    following them by <mimic> (their own joints off the arm's path), a bar on the bracket following the linkage
    motor; a gripper on the bracket whose two jaws are each a planar linkage written open (four continuous joints
    with no range about parallel axes, following nothing, as a file leaves a loop's joints to a solver). The
    bracket, and the two jaws' tips."""
    w = Writer(random.Random(seed))
    base = w.link('<box size="0.3 0.2 0.1"/>')
    upper, fore, bracket = (w.link('<box size="0.02 0.02 0.12"/>') for _ in range(3))
    shoulder = w.joint("revolute", base, upper, (0.0, 0.0, 0.1), (0, 1, 0), limits=(-0.3, 1.4))
    motor = w.link('<box size="0.02 0.02 0.05"/>')
    linkage = w.joint("revolute", base, motor, (0.0, 0.03, 0.1), (0, 1, 0), limits=(-0.8, 1.7))
    w.joint("continuous", upper, fore, (0.0, 0.0, 0.12), (0, 1, 0), mimic=shoulder, multiplier=-1.0)
    w.joint("continuous", fore, bracket, (0.12, 0.0, 0.0), (0, 1, 0), mimic=linkage, multiplier=-1.0)
    w.joint("continuous", bracket, w.link('<box size="0.01 0.01 0.05"/>'), (0.0, -0.03, 0.02), (0, 1, 0),
            mimic=linkage)
    tips = []
    for side in (1.0, -1.0):
        link = bracket
        for k in range(4):
            child = w.link('<box size="0.015 0.005 0.02"/>')
            w.joint("continuous", link, child, (0.03, side * 0.015, 0.0) if k == 0 else (0.015, side * 0.01, 0.0))
            link = child
        tips.append(link)
    return w.urdf(), bracket, tips


def test_jaws_written_as_open_linkages_at_a_parallel_arms_end_make_a_tool_there():
    """A gripper whose jaws are planar linkages written open (every joint continuous, with no range, following
    nothing) at the end of a parallel arm whose elbow and bracket follow motors beside the arm: the jaws' tips end
    free linkages, not wheels that roll (hands.rolling), and the bracket is moved by three joints moving on their own
    (the shoulder and the two its joints follow), so the tool is settled there, not refused as off an arm's end."""
    urdf, bracket, tips = _parallel_arm_with_open_loop_jaws(3)
    tree = load_urdf(urdf)
    assert not any(rolling(tree, tip) for tip in tips)
    notes: list[str] = []
    settled = settle(tree, [Group([sub_chain(tree, tip, bracket) for tip in tips])], lambda leaf: False, notes.append)
    assert [group_root_of(g) for g, _ in settled] == [bracket] and set(tips) <= set(settled[0][0].leaves), notes


@pytest.mark.parametrize("seed", range(4))
def test_a_hand_whose_palm_is_a_chain_of_bolted_pieces_with_a_cover_is_one_hand(seed):
    """A hand on a wrist joint whose palm is written as pieces bolted in series (each finger's base its own link, as
    an open-source hand's CAD export writes it), a thumb and four fingers forking from them, and a drawn cover fixed
    on the palm that the model calls a body part: the cover blocks neither the hand's mount nor its extent, so all
    five fingers and the cover are one hand (on the code before: the index finger one tool, the rest another)."""
    rng = random.Random(seed)
    w = Writer(rng)
    forearm, wrist = w.link('<box size="0.06 0.06 0.2"/>'), w.link('<box size="0.05 0.05 0.03"/>')
    w.joint("revolute", forearm, wrist, (0.0, 0.0, 0.2), (0.0, 1.0, 0.0), (-1.0, 1.0))
    pieces = [w.link('<box size="0.02 0.03 0.08"/>') for _ in range(4)]
    w.joint("revolute", wrist, pieces[0], (0.0, 0.0, 0.03), (1.0, 0.0, 0.0), (-0.5, 0.5))
    for a, b in zip(pieces, pieces[1:]):
        w.joint("fixed", a, b, (0.0, -0.022, 0.0))
    tips = []
    for piece in pieces:
        link = piece
        for i in range(3):
            child = w.link('<box size="0.015 0.015 0.03"/>')
            w.joint("revolute", link, child, (0.0, 0.0, 0.08) if i == 0 else (0.0, 0.0, 0.03), (0.0, 1.0, 0.0),
                    (0.0, 1.5))
            link = child
        tips.append(link)
    link = pieces[1]
    for i, (xyz, axis) in enumerate((((0.03, 0.0, 0.02), (0.0, 0.0, 1.0)), ((0.02, 0.0, 0.0), (0.0, 1.0, 0.0)),
                                     ((0.0, 0.0, 0.03), (0.0, 1.0, 0.0)))):
        child = w.link('<box size="0.015 0.015 0.03"/>')
        w.joint("revolute", link, child, xyz, axis, (-1.5, 0.0) if i else (0.0, 1.5))
        link = child
    tips.append(link)
    cover = w.link('<box size="0.04 0.09 0.01"/>')
    w.joint("fixed", pieces[1], cover, (0.015, -0.01, 0.04))
    tree = load_urdf(w.urdf())

    def answer(q: Question):
        if q.key == f"identify:{cover}":
            return "body part"
        return q.options[0]
    tools = [c for c in Abstractor(Oracle(ScriptedBackend(answer)), TAX, reasoner=scripted_reasoner).run(tree).components
             if c.kind == "end_effector"]
    assert len(tools) == 1 and set(tips) | {cover} <= set(tools[0].links), [(c.cls, c.links) for c in tools]


@pytest.mark.parametrize("seed", range(6))
def test_a_gripper_written_closed_keeps_its_fixed_jaws_tip_and_is_mounted_above_its_jaw(seed):
    """An arm's last link carrying a fixed jaw (a bare tip frame on it) and a moving jaw on one joint, written closed:
    the two tip frames meet at the zero pose. One joint between them closes no kinematic loop (it would hold the jaw
    still), so neither is a loop's cut; the model calls the fixed tip no component and mounts the moving tip on the
    arm's last link, verification absorbs the fixed tip into the tool, and the tool is mounted there with its jaw
    and both tips (on the code before: the tips were no component at all, then a tool on the jaw alone)."""
    rng = random.Random(seed)
    w = Writer(rng)
    link = w.link('<cylinder radius="0.05" length="0.05"/>')
    for _ in range(rng.randint(4, 5)):
        child = w.link('<box size="0.03 0.03 0.06"/>')
        w.joint(rng.choice(["revolute", "continuous"]), link, child, (0.0, 0.0, 0.06), (0.0, 1.0, 0.0), (-2.5, 2.5))
        link = child
    fixed_tip, jaw, moving_tip = w.link(), w.link('<box size="0.01 0.02 0.05"/>'), w.link()
    reach = rng.uniform(0.08, 0.12)
    w.joint("fixed", link, fixed_tip, (0.0, 0.0, reach))
    hinge = rng.uniform(0.04, 0.06)
    w.joint(rng.choice(["revolute", "continuous"]), link, jaw, (0.02, 0.0, hinge), (0.0, 1.0, 0.0), (-1.0, 0.0))
    w.joint("fixed", jaw, moving_tip, (-0.02, 0.0, reach - hinge))
    tree = load_urdf(w.urdf())
    assert not loop_closures(tree)

    def answer(q: Question):
        if q.key == f"identify:{fixed_tip}":
            return NONE
        if q.key == f"identify:{moving_tip}":
            return "end effector"
        if q.key == f"root:{moving_tip}":
            return link
        return q.options[0]
    tools = [c for c in Abstractor(Oracle(ScriptedBackend(answer)), TAX, reasoner=scripted_reasoner).run(tree).components
             if c.kind == "end_effector"]
    assert [(t.root, set(t.links) >= {fixed_tip, jaw, moving_tip}) for t in tools] == [(link, True)], \
        [(t.cls, t.root, t.links) for t in tools]


@pytest.mark.parametrize("seed", range(4))
def test_a_vehicles_lone_propeller_is_no_tool(seed):
    """A hull carrying one propeller on a joint that spins freely and four fins the erring model calls sensors
    (an underwater vehicle): the model calls the propeller an end effector, and it is every leaf left once the
    sensors are out, but all that moves in it spins: no tool (it became a parallel gripper). (A gripper or hand
    described on its own is still one: tests.hand_robots builds them.)"""
    rng = random.Random(seed)
    w = Writer(rng)
    hull = w.link('<cylinder radius="0.1" length="1.4"/>', mass=18.0)
    propeller = w.link('<box size="0.02 0.1 0.1"/>', mass=0.001)
    w.joint("continuous", hull, propeller, (-0.55, 0.0, 0.0), (1.0, 0.0, 0.0))
    fins = [w.link('<box size="0.06 0.002 0.04"/>', mass=0.0001) for _ in range(4)]
    for k, fin in enumerate(fins):
        angle = k * math.pi / 2
        w.joint("revolute", hull, fin, (-0.4, 0.04 * math.sin(angle), 0.04 * math.cos(angle)), (0.0, 0.0, 1.0),
                (-1.57, 1.57))
    tree = load_urdf(w.urdf())

    def answer(q: Question):
        leaf = q.key.split(":", 1)[1].split("@")[0]
        if q.key.startswith("identify:"):
            return "end effector" if leaf == propeller else "sensor"
        return q.options[0]
    found = Abstractor(Oracle(ScriptedBackend(answer)), TAX, reasoner=scripted_reasoner).run(tree).components
    assert not [c for c in found if c.kind == "end_effector"]


@pytest.mark.parametrize("seed", range(4))
def test_a_hand_whose_fingertips_carry_only_declared_tactile_sensors_is_still_a_hand(seed):
    """A three-finger gripper on an arm whose every leaf is a tactile pad the file declares a contact sensor on (each
    fingertip carrying its pads, the palm its own): the sensor pass takes every leaf, and the hand kept none, so it
    was lost and its fingers went to the body pass (typed heads). The fingertips those pads end now end the hand's
    fingers: one tool of all three fingers, its sensors apart."""
    rng = random.Random(seed)
    w = Writer(rng)
    link = w.link('<cylinder radius="0.06" length="0.1"/>')
    for _ in range(5):
        child = w.link('<box size="0.05 0.05 0.2"/>')
        w.joint("revolute", link, child, (0.0, 0.0, 0.2), (0.0, 1.0, 0.0), (-2.0, 2.0))
        link = child
    palm = w.link('<box size="0.08 0.08 0.03"/>')
    w.joint("fixed", link, palm, (0.0, 0.0, 0.05))
    pads = [w.link('<box size="0.04 0.04 0.005"/>')]
    w.joint("fixed", palm, pads[0], (0.0, 0.0, 0.02))
    tips = []
    for angle in (0.0, 2.1, 4.2):
        x, y = 0.03 * math.cos(angle), 0.03 * math.sin(angle)
        proximal, distal = w.link('<box size="0.015 0.015 0.05"/>'), w.link('<box size="0.015 0.015 0.04"/>')
        w.joint("revolute", palm, proximal, (x, y, 0.02), (-y / 0.03, x / 0.03, 0.0), (0.0, 1.5))
        w.joint("revolute", proximal, distal, (0.0, 0.0, 0.05), (-y / 0.03, x / 0.03, 0.0), (0.0, 1.0))
        for z in (0.01, 0.03)[:rng.randint(1, 2)]:
            pad = w.link('<box size="0.01 0.01 0.002"/>')
            w.joint("fixed", distal, pad, (-x / 3, -y / 3, z))
            pads.append(pad)
        tips.append(distal)
    block = "".join(f'<gazebo reference="{p}"><sensor name="{p}_contact" type="contact"/></gazebo>' for p in pads)
    tree = load_urdf(w.urdf().replace(b"</robot>", block.encode() + b"</robot>"))
    found = Abstractor(Oracle(ScriptedBackend(lambda q: q.options[0])), TAX, reasoner=scripted_reasoner).run(tree)
    tools = [c for c in found.components if c.kind == "end_effector"]
    assert len(tools) == 1 and set(tips) <= set(tools[0].links), [(c.kind, c.cls, c.links) for c in found.components]
    assert {p for c in found.components if c.kind == "sensor" for p in c.links} == set(pads)
