"""What the robot's shape settles before any question (pipeline.abstraction.hands: hand_leaves, feet), on generated
robots with known truth, and with a scripted model that makes the small model's mistakes: it claims fingertips
for sensors, and a quadruped's feet for tools. Names are meaningless, so only structure can correct it."""
from __future__ import annotations

import math
import random

import pytest
from tests.body_robots import legged, wheeled
from tests.hand_robots import build
from tests.urdf_writer import Writer

from urdfkb.pipeline.abstraction.abstractor import SENSOR_PASS, Abstractor
from urdfkb.pipeline.abstraction.components import Abstraction
from urdfkb.pipeline.reading.ingest import load_urdf
from urdfkb.pipeline.llm.base import Question
from urdfkb.pipeline.llm.scripted import ScriptedBackend
from urdfkb.pipeline.abstraction.oracle import Oracle
from urdfkb.pipeline.knowledge.ontology import vocabulary
from urdfkb.pipeline.abstraction.prompts import NONE
from urdfkb.pipeline.abstraction.stages.attachment import detect_roots
from urdfkb.pipeline.abstraction.steps.findings import Findings
from urdfkb.pipeline.abstraction.alike import alike_leaves
from urdfkb.pipeline.abstraction.hands import (feet, frozen_fingertips, hand_leaves, hand_mounts, hands, jaw_pairs,
                                              last_segments,
                                              limb_ends, off_limb_ends, rolling, spinning_low, spinning_on_trunk,
                                              swinging_leaves)
from urdfkb.pipeline.abstraction.frames import collision_volumes, loop_closures, rods, struts

TAX = vocabulary()
SEEDS = range(300)
SENSOR_CLS, TOOL_CLS = TAX.kinds["sensor"].cls, TAX.kinds["end_effector"].cls


def _chain_leaves(built, tree) -> set[str]:
    return {link for chain in built.chains for link in chain.links if tree.is_leaf(link)}


def _leg_tips(built, tree) -> set[str]:
    tips = set()
    for part in built.parts:
        if part.cls == "Leg":
            last = next(e.child for e in tree.edges if e.joint == part.joints[-1])
            tips |= {link for link in (last, *tree.descendants(last)) if tree.is_leaf(link)}
    return tips


@pytest.mark.slow  # many generated robots
@pytest.mark.parametrize("alone", [False, True])
def test_hand_leaves_are_the_tools_leaves_and_nothing_else(alone):
    """Every leaf of the generated gripper or hand (fingertips, tip frames, the TCP frame), none of the arm's."""
    wrong = []
    for seed in SEEDS:
        built = build(seed, alone)
        tree = load_urdf(built.urdf)
        if hand_leaves(tree) != set(built.leaves) or feet(tree):
            wrong.append((seed, built.layout))
    assert not wrong


@pytest.mark.slow  # over a second of its own (make test-fast leaves it out)
def test_wheels_and_casters_are_no_fingers():
    for seed in range(0, 300, 3):
        tree = load_urdf(wheeled(seed).urdf)
        wheels = {leaf for leaf in tree.leaves() if tree.edge_to(leaf).joint_type == "continuous"}
        assert wheels and not wheels & hand_leaves(tree), seed


@pytest.mark.slow  # many generated robots
def test_feet_are_the_leg_tips_of_legged_robots_and_wheels_are_no_feet():
    wrong = []
    for seed in SEEDS:
        for make in (legged, wheeled):
            built = make(seed)
            tree = load_urdf(built.urdf)
            if feet(tree) != _leg_tips(built, tree):
                wrong.append((make.__name__, seed))
    assert not wrong


def _identified(urdf: bytes, rule) -> dict[str, str]:
    """The leaves' kinds after the sensor pass's shape and identification steps, answered by `rule`."""
    tree = load_urdf(urdf)
    abstractor = Abstractor(Oracle(ScriptedBackend(rule)), TAX)
    context, found = abstractor.context(tree, kind="sensor"), Findings()
    for step in SENSOR_PASS.steps[:2]:
        step(context, found)
    return found.claims


def _leaf(question) -> str:
    return question.key.split(":", 1)[1]


def test_fingertips_the_model_takes_for_sensors_go_to_the_tool():
    """The erring model says "sensor" at 0.6 for every finger leaf: none of them is a sensor after all."""
    for seed in range(0, 300, 7):
        built = build(seed)
        tree = load_urdf(built.urdf)
        tips = _chain_leaves(built, tree)
        options = {TAX.answer(SENSOR_CLS): 0.6, TAX.answer(TOOL_CLS): 0.4}
        claims = _identified(built.urdf, lambda q: options if _leaf(q) in tips else NONE)
        assert {leaf: claims[leaf] for leaf in tips} == dict.fromkeys(tips, TOOL_CLS), seed


def test_the_leaves_of_a_fingers_linkage_the_model_takes_for_sensors_go_to_the_tool():
    """A hand whose four-bar linkages are written as branches (a crank beside each finger, bars on its pins), the
    erring model saying "sensor" at 0.6 for every leaf of it, as it said of such bars: the cranks' and the bars'
    leaves go to the tool with the fingertips."""
    for seed in range(0, 300, 7):
        built = build(seed, linkages=True)
        leaves = built.moving_leaves
        options = {TAX.answer(SENSOR_CLS): 0.6, TAX.answer(TOOL_CLS): 0.4}
        claims = _identified(built.urdf, lambda q: options if _leaf(q) in leaves else NONE)
        assert {leaf: claims[leaf] for leaf in leaves} == dict.fromkeys(leaves, TOOL_CLS), seed


def _hand(w: Writer, palm: str, sign: float) -> tuple[list[str], list[str]]:
    """A thumb facing two fingers that follow it by <mimic> (multiplier -2), as some exports write a hand; `sign`
    -1 mirrors the ranges (a right hand written with the left one's axes: the thumb closes negatively). Its finger
    chains (their first links) and their tip frames."""
    chains, tips = [], []
    for k, x in enumerate((0.0, 0.025, -0.025)):
        finger, tip = w.link('<box size="0.02 0.02 0.045"/>'), w.link()
        closing = (0.0, 0.785) if (k == 0) == (sign > 0) else (-0.785, 0.0)
        if k == 0:
            drive = w.joint("revolute", palm, finger, (x, -0.023 * sign, -0.08), (1.0, 0.0, 0.0), limits=closing)
        else:
            w.joint("revolute", palm, finger, (x, 0.006 * sign, -0.1), (1.0, 0.0, 0.0),
                    limits=(2 * closing[0], 2 * closing[1]), mimic=drive, multiplier=-2.0)
        w.joint("fixed", finger, tip, (0.0, 0.0, -0.045))
        chains.append(finger)
        tips.append(tip)
    return chains, tips


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_fingers_following_a_thumb_that_closes_negatively_still_close_on_it(sign):
    """A hand whose fingers follow the thumb turning the other way (<mimic>, multiplier -2): the thumb closes as its
    range reaches, and the fingers as it closes. The right hand of a file that wrote it with mirrored ranges (its
    thumb closing negatively) was three mechanisms and no hand, its fingers typed arms and a head."""
    w = Writer(random.Random(11))
    palm = w.link('<box size="0.08 0.03 0.08"/>')
    wrist = _serial(w, palm, 0)
    chains, _ = _hand(w, wrist, sign)
    found = hands(load_urdf(w.urdf()))
    assert [sorted(f.name for f in structure.fingers) for structure, _ in found] == [sorted(chains)]


def test_an_upper_bodys_hands_hanging_lowest_are_no_feet():
    """A torso on a pedestal, a head and two arms hanging down, each ending in a hand: the fingertips are the lowest
    links, as a standing robot's feet are, but their limbs leave a torso that carries a head: they are hands (the
    fingertips read as feet became buttons and gyroscopes, and every limb a leg)."""
    w = Writer(random.Random(12))
    pedestal = w.link('<box size="0.3 0.3 0.5"/>')
    torso = w.link('<box size="0.3 0.2 0.4"/>')
    w.joint("revolute", pedestal, torso, (0.0, 0.0, 0.5), limits=(-1.0, 1.0))
    head = w.link('<box size="0.15 0.15 0.15"/>')
    w.joint("revolute", torso, head, (0.0, 0.0, 0.3), limits=(-1.0, 1.0))
    tips = []
    for y in (0.2, -0.2):
        link = torso
        for k in range(4):
            child = w.link('<box size="0.05 0.05 0.3"/>')
            w.joint("revolute", link, child, (0.0, y, 0.2) if k == 0 else (0.0, 0.0, -0.3),
                    (0.0, 1.0, 0.0) if k % 2 == 0 else (1.0, 0.0, 0.0), limits=(-1.5, 1.5))
            link = child
        tips += _hand(w, link, 1.0 if y > 0 else -1.0)[1]
    tree = load_urdf(w.urdf())
    assert tree.position_in(tips[0], tree.root)[2] < -0.15  # the fingertips hang lowest, below the root
    assert feet(tree) == frozenset()
    assert sorted(leaf for _, leaves in hands(tree) for leaf in leaves) == sorted(tips)


def test_the_jaws_of_an_arm_hanging_below_a_vehicle_are_no_feet():
    """An underwater vehicle's arm hangs below its hull and ends in two jaws, the lowest links: but legs part where
    the feet meet with two joints or more each, and the jaws part at the gripper with one each: no feet."""
    w = Writer(random.Random(13))
    hull = w.link('<box size="1.0 0.6 0.4"/>')
    link = hull
    for k in range(5):
        child = w.link('<box size="0.05 0.05 0.15"/>')
        w.joint("revolute", link, child, (0.4, 0.0, -0.2) if k == 0 else (0.0, 0.0, -0.15),
                (0.0, 1.0, 0.0) if k % 2 else (0.0, 0.0, 1.0), limits=(-1.5, 1.5))
        link = child
    jaws = []
    for y in (0.03, -0.03):
        jaw = w.link('<box size="0.01 0.01 0.06"/>')
        w.joint("revolute", link, jaw, (0.0, y, -0.1), (1.0, 0.0, 0.0), limits=(0.0, 1.0))
        jaws.append(jaw)
    tree = load_urdf(w.urdf())
    assert all(tree.position_in(jaw, tree.root)[2] < -0.7 for jaw in jaws)
    assert feet(tree) == frozenset()


def test_the_fingers_of_a_gripper_hanging_lowest_on_an_arm_are_no_feet():
    """A free flyer's arm hangs below its body and ends in a gripper of two fingers of two joints each, its lowest
    links: they part with two joints each, as legs do, but a few centimetres above their tips, where legs part
    STANCE or more above their feet: no feet (the arm and gripper were typed three legs), a gripper."""
    w = Writer(random.Random(17))
    body = w.link('<box size="0.3 0.3 0.3"/>')
    proximal, distal = w.link('<box size="0.03 0.03 0.1"/>'), w.link('<box size="0.03 0.03 0.1"/>')
    w.joint("revolute", body, proximal, (0.0, 0.0, -0.15), (0.0, 1.0, 0.0), limits=(-1.5, 1.5))
    w.joint("revolute", proximal, distal, (0.0, 0.0, -0.1), (0.0, 1.0, 0.0), limits=(-1.5, 1.5))
    tips = []
    for y in (0.02, -0.02):
        link, start = distal, (0.0, y, -0.05)
        for k in range(2):
            child = w.link('<box size="0.01 0.01 0.02"/>')
            w.joint("revolute", link, child, start, (y / abs(y), 0.0, 0.0), limits=(-1.0, 0.0) if k else (0.0, 1.0))
            link, start = child, (0.0, 0.0, -0.02)
        tips.append(link)
    tree = load_urdf(w.urdf())
    assert all(tree.position_in(tip, tree.root)[2] < -0.25 for tip in tips)  # the lowest links, 0.3 below the body
    assert feet(tree) == frozenset()
    assert sorted(leaf for _, leaves in hands(tree) for leaf in leaves) == sorted(tips)


def _biped(w: Writer, trunk: str, rod: bool) -> list[str]:
    """Two legs of four joints hanging from `trunk`, each ending in a sole frame, `rod`: with a bar on its own
    continuous joint hanging from each thigh (a loop-cut linkage rod). The soles."""
    soles = []
    for y in (0.1, -0.1):
        link = trunk
        for k in range(4):
            child = w.link('<box size="0.05 0.05 0.2"/>')
            w.joint("revolute", link, child, (0.0, y, -0.1) if k == 0 else (0.0, 0.0, -0.2), (0.0, 1.0, 0.0),
                    limits=(-1.0, 1.0))
            if rod and k == 1:
                bar = w.link('<cylinder radius="0.01" length="0.2"/>')
                w.joint("continuous", child, bar, (0.03, 0.0, 0.0), (0.0, 1.0, 0.0))
            link = child
        sole = w.link()
        w.joint("fixed", link, sole, (0.0, 0.0, -0.2))
        soles.append(sole)
    return soles


@pytest.mark.parametrize("rod", [False, True])
def test_a_legs_own_bars_and_a_trunks_arm_leave_its_feet_feet(rod):
    """A biped whose thighs carry linkage rods on joints of their own (as Cassie's do), and a quadruped carrying an arm
    on a trunk that virtual x, y and yaw joints place: the rods belong to the legs and the arm to the trunk, so the
    soles are feet."""
    w = Writer(random.Random(14))
    pelvis = w.link('<box size="0.2 0.3 0.1"/>')
    soles = _biped(w, pelvis, rod)
    assert feet(load_urdf(w.urdf())) == set(soles)
    w = Writer(random.Random(15))
    world, vx, vy = w.link(), w.link(), w.link()
    w.joint("prismatic", world, vx, axis=(1.0, 0.0, 0.0), limits=(-5.0, 5.0))
    w.joint("prismatic", vx, vy, axis=(0.0, 1.0, 0.0), limits=(-5.0, 5.0))
    trunk = w.link('<box size="0.6 0.3 0.15"/>')
    w.joint("continuous", vy, trunk, (0.0, 0.0, 0.9))
    soles = _biped(w, trunk, rod) + _biped(w, trunk, rod)
    _serial(w, trunk, 5)
    assert feet(load_urdf(w.urdf())) == set(soles)


@pytest.mark.parametrize("seed", [31, 32])
def test_a_standoff_whose_mirror_twin_holds_a_plate_is_no_sensor(seed):
    """Two short posts drawn alike on a beam, mirror images across the robot's x-z plane, one holding up a sensor
    plate (with its sonar), the other a bare leaf: the erring model calls the bare one a sensor (0.89), but it is the
    plate's second standoff (frames.struts), a piece of structure (on the code before: a lidar, 0.85). The sonar on the
    plate, and a lone drawn leaf with no twin, stay the model's."""
    rng = random.Random(seed)
    w = Writer(rng)
    base = w.link('<box size="0.6 0.5 0.2"/>')
    beam = w.link('<box size="0.03 0.3 0.03"/>')
    w.joint("fixed", base, beam, (0.25, 0.0, 0.3))
    post = '<cylinder radius="0.0064" length="0.0127"/>'
    holding, bare = w.link(post), w.link(post)
    y = rng.uniform(0.05, 0.12)
    w.joint("fixed", beam, holding, (0.0, y, 0.02))
    w.joint("fixed", beam, bare, (0.0, -y, 0.02))
    plate, sonar, lone = w.link('<box size="0.1 0.3 0.003"/>'), w.link('<box size="0.012 0.044 0.023"/>'), w.link(post)
    w.joint("fixed", holding, plate, (0.0, -y, 0.01))
    w.joint("fixed", plate, sonar, (0.05, 0.0, 0.01))
    w.joint("fixed", base, lone, (-0.2, 0.1, 0.15))
    tree = load_urdf(w.urdf())
    assert struts(tree) == {bare}
    erring = {TAX.answer(SENSOR_CLS): 0.89, TAX.answer(TOOL_CLS): 0.03, NONE: 0.08}
    claims = _identified(w.urdf(), lambda q: erring)
    assert claims.get(bare, NONE) == NONE and claims[sonar] == SENSOR_CLS and claims[lone] == SENSOR_CLS


def test_a_lone_spinner_is_left_to_the_model():
    """One leaf spinning from the trunk (a spindle, a mower's blade) may be the robot's tool: the model's "end
    effector" stands; two or more (wheels, rotors, thrusters) are no tools."""
    w = Writer(random.Random(16))
    chassis = w.link('<box size="0.5 0.4 0.1"/>')
    blade = w.link('<cylinder radius="0.2" length="0.01"/>')
    w.joint("continuous", chassis, blade, (0.0, 0.0, -0.05))
    tool = {TAX.answer(TOOL_CLS): 0.9, TAX.answer(SENSOR_CLS): 0.05, NONE: 0.05}
    assert spinning_on_trunk(load_urdf(w.urdf())) == frozenset()
    assert _identified(w.urdf(), lambda q: tool)[blade] == TOOL_CLS


def test_feet_the_model_takes_for_tools_are_no_tools():
    """The erring model calls every leg tip a tool at 0.7 (a quadruped's four lower legs became four grippers):
    they are parts of the body."""
    for seed in range(0, 300, 7):
        built = legged(seed)
        tree = load_urdf(built.urdf)
        tips = _leg_tips(built, tree)
        tool = {TAX.answer(TOOL_CLS): 0.7, NONE: 0.3}
        claims = _identified(built.urdf, lambda q: tool if _leaf(q) in tips else NONE)
        assert {leaf: claims[leaf] for leaf in tips} == dict.fromkeys(tips, "BodyPart"), seed


def test_leaves_at_no_limbs_end_are_never_tools():
    """A box bolted along the arm (a limb goes on from it) and one bolted beside the hand on the link its palm is
    bolted to are at no limb's end; the hand's own leaves are. The erring model calls the boxes end effectors at
    0.6: structure rules that out, so they get the model's next answer, and the hand's leaves stay the tool's."""
    seen = 0
    for seed in range(0, 300, 7):
        built = build(seed, asides=True)
        tree = load_urdf(built.urdf)
        off = off_limb_ends(tree, hands(tree))
        assert set(built.asides) <= off and not off & set(built.leaves), (seed, built.layout)
        options = {TAX.answer(TOOL_CLS): 0.6, TAX.answer(SENSOR_CLS): 0.3, NONE: 0.1}
        claims = _identified(built.urdf, lambda q: options if _leaf(q) in built.asides else NONE)
        assert {a: claims[a] for a in built.asides} == dict.fromkeys(built.asides, SENSOR_CLS), seed
        assert {claims[leaf] for leaf in built.leaves} == {TOOL_CLS}, seed
        seen += len(built.asides)
    assert seen >= 40


@pytest.mark.parametrize("bare_feet", [True, False])
def test_a_legs_last_link_or_its_foot_on_the_ground_is_part_of_the_body_unasked(bare_feet):
    """Where no foot is fixed at a leg's tip, the leaf the robot stands on is the leg's last moving link; where a
    ball or a sole is, that body is the foot. The erring model calls it a sensor at 0.6 (a humanoid's ankle roll
    links became touch sensors, taking the ankle joints out of the legs; a quadruped's numbered toes force-torque
    sensors): it is part of the body, and it is not asked."""
    for seed in range(0, 300, 7):
        built = legged(seed, bare_feet=bare_feet)
        tree = load_urdf(built.urdf)
        tips = _leg_tips(built, tree)
        assert tips == set(feet(tree)) and all(tree.edge_to(t).movable == bare_feet for t in tips), seed
        asked = []

        def erring(q):
            asked.append(_leaf(q))
            return {TAX.answer(SENSOR_CLS): 0.6, NONE: 0.4} if _leaf(q) in tips else NONE
        claims = _identified(built.urdf, erring)
        assert {leaf: claims[leaf] for leaf in tips} == dict.fromkeys(tips, "BodyPart") and not tips & set(asked), seed


def test_alike_limbs_are_asked_once_and_answered_alike():
    """The contact frames at the feet of a generated legged robot are one set of alike leaves: one identification
    question, whose answer all of them get, even from a model that would have told them apart (by a meaningless
    name)."""
    for seed in range(0, 300, 11):
        built = legged(seed, frame_feet=True)
        tree = load_urdf(built.urdf)
        tips = _leg_tips(built, tree)
        assert sorted(tips) in [sorted(g) for g in alike_leaves(tree, list(tree.leaves()))], seed
        asked = []

        def fickle(q):
            asked.append(_leaf(q))
            return TAX.answer(SENSOR_CLS) if _leaf(q) == min(tips) else NONE
        claims = _identified(built.urdf, fickle)
        assert len(set(asked) & tips) == 1 and len({claims[t] for t in tips}) == 1, seed


def test_fixed_frames_side_by_side_are_never_alike():
    """Two frames bolted at equal distances on one body (a camera and an IMU) are no pair; two jaws sliding
    on it, mirrored, are."""
    w = Writer(random.Random(3))
    body = w.link()
    frames, jaws = [w.link() for _ in range(2)], [w.link() for _ in range(2)]
    for frame, jaw, y in zip(frames, jaws, (1.0, -1.0)):
        w.joint("fixed", body, frame, (0.0, 0.1 * y, 0.05))
        w.joint("prismatic", body, jaw, (0.05, 0.02 * y, 0.0), (0.0, y, 0.0), (0.0, 0.03))
    tree = load_urdf(w.urdf())
    assert sorted(map(sorted, alike_leaves(tree, list(tree.leaves())))) == sorted([sorted(jaws), [frames[0]], [frames[1]]])


@pytest.mark.slow  # many generated robots
def test_a_hands_leaves_are_mounted_where_its_shape_says_unasked():
    """The end-effector pass asks no mount for a hand's leaves: the shape gives the hand's mount (the link its
    palm is bolted to), even where the model would have named another."""
    for seed in range(0, 300, 5):
        built = build(seed, False)
        tree = load_urdf(built.urdf)
        mounts = hand_mounts(tree, hands(tree))
        assert set(mounts.values()) == {built.mount}, (seed, built.layout)
        asked: list[str] = []

        def last_option(question: Question) -> str:
            asked.append(question.key)
            return question.options[-1]
        chains = detect_roots(Oracle(ScriptedBackend(last_option)), tree,
                              sorted(mounts), TAX.kinds["end_effector"], lambda _link: False, settled=mounts)
        assert not asked and {c.root for c in chains} == {built.mount}, (seed, built.layout)


def _platform(seed: int) -> tuple[bytes, list[str], list[str]]:
    """A base carrying a head by 3-6 rods of two ball-like revolute joints each (a Stewart platform): the tree is
    cut where each rod meets the head, leaving a frame on the rod's end and one on the head at the same point; and
    a camera on the head with a frame and its optical twin (they coincide with nothing moving between them)."""
    rng = random.Random(seed)
    w = Writer(rng)
    base, lift, head = w.link('<box size="0.2 0.2 0.05"/>'), w.link(), w.link('<box size="0.15 0.15 0.03"/>')
    height = rng.uniform(0.35, 0.5)  # rods longer than a hand's fingers
    w.joint("prismatic", base, lift, axis=(0.0, 0.0, 1.0), limits=(0.0, 0.02))
    w.joint("fixed", lift, head, (0.0, 0.0, height))
    cuts = []
    for i in range(rng.randint(3, 6)):
        angle = 2 * math.pi * i / 6 + rng.uniform(-0.2, 0.2)
        foot = (0.08 * math.cos(angle), 0.08 * math.sin(angle), 0.03)
        top = (0.05 * math.cos(angle + 0.4), 0.05 * math.sin(angle + 0.4), height)
        arm, rod, rod_end, head_end = w.link(), w.link('<cylinder radius="0.003" length="0.4"/>'), w.link(), w.link()
        w.joint("revolute", base, arm, foot, axis=(0.0, 0.0, 1.0), limits=(-1.0, 1.0))
        w.joint("revolute", arm, rod, (0.0, 0.0, 0.0), axis=(1.0, 0.0, 0.0), limits=(-1.0, 1.0))
        w.joint("fixed", rod, rod_end, tuple(t - f for t, f in zip(top, foot)))
        w.joint("fixed", head, head_end, (top[0], top[1], 0.0))
        cuts += [rod_end, head_end]
    camera, frame, optical = w.link('<box size="0.02 0.06 0.02"/>'), w.link(), w.link()
    w.joint("fixed", head, camera, (0.07, 0.0, 0.02))
    w.joint("fixed", camera, frame)
    w.joint("fixed", camera, optical, rpy=(-math.pi / 2, 0.0, -math.pi / 2))
    return w.urdf(), cuts, [frame, optical]


@pytest.mark.parametrize("seed", range(20))
def test_frames_where_a_closed_loop_is_cut_are_no_component_and_not_asked(seed):
    """The erring model calls every leaf a sensor (Reachy Mini's Stewart-platform closing frames became buttons):
    the frames that coincide across a moving joint are part of no component and are not asked; the camera's two
    coinciding frames, on one link, are asked as ever."""
    urdf, cuts, camera = _platform(seed)
    assert loop_closures(load_urdf(urdf)) == set(cuts)
    asked = []

    def erring(q):
        asked.append(_leaf(q))
        return {TAX.answer(SENSOR_CLS): 0.7, NONE: 0.3}
    claims = _identified(urdf, erring)
    assert {claims[c] for c in cuts} == {NONE} and not set(cuts) & set(asked)
    assert {claims[c] for c in camera} == {SENSOR_CLS}


def _serial(w: Writer, parent: str, joints: int, ranges: tuple[float, float] | None = None) -> str:
    """`joints` revolute links in series below `parent`, each with a box; the last one's name."""
    link = parent
    for i in range(joints):
        child = w.link('<box size="0.05 0.05 0.15"/>')
        w.joint("revolute", link, child, (0.0, 0.0, 0.15), (0.0, 0.0, 1.0) if i % 2 == 0 else (0.0, 1.0, 0.0), ranges)
        link = child
    return link


def test_the_last_link_of_a_bare_arm_is_no_sensor_whatever_the_model_says():
    """A bare arm (four to seven joints, nothing on its flange): the erring model calls its last link a sensor at 0.6
    (an industrial arm's flange link became a camera, which then made the arm a head). A leaf moving on its own joint
    at the end of a limb is the limb's, a jaw or a finger: it gets the model's next answer (none where it rolls, as the
    seventh joint here turns about the line out to it). One joint or two above a leaf make no limb (a lidar's
    spinning head, a camera on a pan and tilt), and neither does a joint with no range."""
    for seed, joints, answer in ((0, 4, TOOL_CLS), (1, 6, TOOL_CLS), (2, 7, NONE)):
        w = Writer(random.Random(seed))
        base = w.link('<cylinder radius="0.1" length="0.2"/>')
        end = _serial(w, base, joints)
        tree = load_urdf(w.urdf())
        assert limb_ends(tree) == {end} and rolling(tree, end) == (answer == NONE)
        options = {TAX.answer(SENSOR_CLS): 0.6, TAX.answer(TOOL_CLS): 0.3, NONE: 0.1}
        assert _identified(w.urdf(), lambda q: options if _leaf(q) == end else NONE)[end] == answer, seed
    w = Writer(random.Random(3))
    base = w.link('<box size="0.4 0.3 0.2"/>')
    lidar = _serial(w, base, 1, (-3.1, 3.1))
    camera = _serial(w, _serial(w, base, 1), 2)  # a camera on a pan and tilt: three joints from the base
    held = w.link('<box size="0.02 0.02 0.02"/>')  # a force sensor's frame on a joint with no range, at an arm's end
    w.joint("revolute", _serial(w, base, 6), held, limits=(0.0, 0.0))
    tree = load_urdf(w.urdf())
    assert not limb_ends(tree) & {lidar, camera, held}
    sensor = {TAX.answer(SENSOR_CLS): 0.6, NONE: 0.4}
    claims = _identified(w.urdf(), lambda q: sensor if _leaf(q) in (lidar, camera, held) else NONE)
    assert [claims[leaf] for leaf in (lidar, camera, held)] == [SENSOR_CLS] * 3


@pytest.mark.parametrize("seed", range(8))
def test_bars_swinging_beside_an_arm_are_no_sensors(seed):
    """An arm whose parallelogram bars are written as branches, each on its own joint beside the joint that carries
    the arm on (as small desktop arms' files do): the erring model calls every bar a sensor at 0.6 (they became
    cameras). They get its next answer. A camera that ends a pan and tilt, a lidar tilting on its own joint on a lift
    beside the lift's pan and tilt, and two antennas on a head (beside each other, not beside a chain going on) are
    not bars: the model decides."""
    rng = random.Random(seed)
    w = Writer(rng)
    base = w.link('<box size="0.4 0.3 0.2"/>')
    upper = _serial(w, _serial(w, base, 1), 1)
    forearm = w.link('<box size="0.04 0.04 0.15"/>')
    w.joint("revolute", upper, forearm, (0.0, 0.0, 0.15), (0.0, 1.0, 0.0), (-2.0, 2.0))
    _serial(w, forearm, 2)
    bars = []
    for link in (upper, forearm):  # each bar beside the joint that carries the arm on
        bars.append(w.link('<box size="0.01 0.01 0.12"/>'))
        w.joint("revolute", link, bars[-1], (0.0, rng.uniform(0.01, 0.03), 0.0), (0.0, 1.0, 0.0), (-1.5, 1.5))
    camera = _serial(w, base, 2)  # a camera ending a pan and tilt
    lift = w.link('<box size="0.2 0.2 0.1"/>')
    w.joint("prismatic", base, lift, (0.0, 0.0, 0.3), (0.0, 0.0, 1.0), (0.0, 0.4))
    tilting = _serial(w, lift, 1, (-0.5, 0.5))  # on a lift, beside the lift's own pan and tilt
    _serial(w, lift, 2)
    head = _serial(w, base, 2)  # a head at the end of a neck of two joints, two antennas on their own joints
    for side in (1.0, -1.0):  # (each beside a leaf: no chain goes on beside them)
        w.joint("revolute", head, w.link('<cylinder radius="0.005" length="0.1"/>'), (0.0, side * 0.05, 0.1),
                (1.0, 0.0, 0.0), (-1.57, 1.57))
    tree = load_urdf(w.urdf())
    assert swinging_leaves(tree) == set(bars)
    sensor = {TAX.answer(SENSOR_CLS): 0.6, NONE: 0.4}
    claims = _identified(w.urdf(), lambda q: sensor if _leaf(q) in (*bars, camera, tilting) else NONE)
    assert [claims[leaf] for leaf in bars] == [NONE, NONE]
    assert claims[camera] == claims[tilting] == SENSOR_CLS


def test_a_flange_turning_about_its_own_centre_of_mass_is_no_tool_wherever_its_joint_sits():
    """A bare arm's flange link on a wrist roll of a quarter turn each way, its joint set beside the line of the arm
    (as an offset wrist's file does: the line out to it runs 20 degrees off the axis), its centre of mass on the
    axis, 3 mm along it: it turns about itself, as no jaw does, so the erring model's end effector (0.6) does not
    stand. The same link with its centre of mass written at the joint's origin says nothing of that (files leave it
    there), nor does a jaw whose mass lies 20 mm off its hinge: both stay the model's tool."""
    found = {}
    for name, centre, axis in (("flange", (0.0034, 0.0, 0.0), (1.0, 0.0, 0.0)), ("unplaced", (0.0, 0.0, 0.0), (1.0, 0.0, 0.0)),
                               ("jaw", (0.0, 0.02, 0.0), (1.0, 0.0, 0.0))):
        w = Writer(random.Random(9))
        base = w.link('<cylinder radius="0.1" length="0.2"/>')
        end = w.link('<cylinder radius="0.04" length="0.02"/>', centre=centre)
        w.joint("revolute", _serial(w, base, 5), end, (0.123, -0.045, 0.0), axis, limits=(-1.57, 1.57))
        tree = load_urdf(w.urdf())
        assert end in limb_ends(tree)
        erring = {TAX.answer(TOOL_CLS): 0.6, TAX.answer(SENSOR_CLS): 0.3, NONE: 0.1}
        found[name] = (rolling(tree, end), _identified(w.urdf(), lambda q: erring if _leaf(q) == end else NONE)[end])
    assert found == {"flange": (True, NONE), "unplaced": (False, TOOL_CLS), "jaw": (False, TOOL_CLS)}


def test_a_bare_arms_last_link_that_rolls_is_no_tool_either():
    """A bare industrial arm's flange link turns through more than half a turn (here +-3 rad, or without bound), or
    about the line out to it from the link before, whatever its range (a quarter turn each way, as some files limit
    a wrist roll): the erring model calls it an end effector at 0.6 and a sensor at 0.3 (a one-finger parallel
    gripper). No jaw or finger turns so far, or about the line it hangs out along, so neither stands; a jaw at the
    end of an arm (a quarter turn about a hinge across that line) stays the model's tool."""
    for seed, kind, limits in ((4, "revolute", (-3.0, 3.0)), (5, "continuous", None), (7, "revolute", (-1.57, 1.57))):
        w = Writer(random.Random(seed))
        base = w.link('<cylinder radius="0.1" length="0.2"/>')
        flange = w.link('<cylinder radius="0.04" length="0.02"/>')
        w.joint(kind, _serial(w, base, 5), flange, (0.0, 0.0, 0.1), limits=limits)
        assert rolling(load_urdf(w.urdf()), flange)
        erring = {TAX.answer(TOOL_CLS): 0.6, TAX.answer(SENSOR_CLS): 0.3, NONE: 0.1}
        assert _identified(w.urdf(), lambda q: erring if _leaf(q) == flange else NONE)[flange] == NONE, seed
    w = Writer(random.Random(6))
    base = w.link('<cylinder radius="0.1" length="0.2"/>')
    jaw = w.link('<box size="0.02 0.01 0.06"/>')
    w.joint("revolute", _serial(w, base, 6), jaw, (0.02, 0.0, 0.05), (0.0, 1.0, 0.0), limits=(-1.57, 0.0))
    assert not rolling(load_urdf(w.urdf()), jaw)
    tool = {TAX.answer(TOOL_CLS): 0.6, TAX.answer(SENSOR_CLS): 0.3, NONE: 0.1}
    assert _identified(w.urdf(), lambda q: tool if _leaf(q) == jaw else NONE)[jaw] == TOOL_CLS


def _servo_humanoid(seed: int, servo: tuple[float, float], grippers: bool = False) -> tuple[bytes, list[str], list[str]]:
    """A small humanoid whose joints all turn through `servo`: two legs of six joints, two arms of three hanging
    beside the trunk (as long as a large hand's fingers), a head on a pan and tilt; with `grippers`, two jaws of 3 cm
    on each forearm. The arms' last links and the jaws."""
    w = Writer(random.Random(seed))
    trunk = w.link('<box size="0.1 0.15 0.12"/>')
    forearms, jaws = [], []
    for y in (0.08, -0.08):
        link = trunk
        for k in range(6):
            child = w.link('<box size="0.03 0.03 0.04"/>')
            w.joint("revolute", link, child, (0.0, y / 2, -0.06) if k == 0 else (0.0, 0.0, -0.04),
                    (0.0, 0.0, 1.0) if k == 0 else (0.0, 1.0, 0.0), limits=servo)
            link = child
        link = trunk
        for k in range(3):  # the forearm's mass hangs below its elbow
            child = w.link('<box size="0.03 0.03 0.08"/>', centre=(0.0, 0.0, -0.05) if k == 2 else None)
            w.joint("revolute", link, child, (0.0, y, 0.05) if k == 0 else (0.0, 0.0, -0.08),
                    (0.0, 1.0, 0.0) if k == 0 else (1.0, 0.0, 0.0), limits=servo)
            link = child
        forearms.append(link)
        for side in (1.0, -1.0) if grippers else ():
            jaws.append(w.link('<box size="0.005 0.01 0.03"/>'))
            w.joint("prismatic", link, jaws[-1], (side * 0.01, 0.0, -0.09), (side, 0.0, 0.0), limits=(-0.01, 0.0))
    pan = w.link('<cylinder radius="0.02" length="0.02"/>')
    w.joint("revolute", trunk, pan, (0.0, 0.0, 0.08), limits=servo)
    tilt = w.link('<box size="0.06 0.06 0.06"/>')
    w.joint("revolute", pan, tilt, (0.0, 0.0, 0.03), (0.0, 1.0, 0.0), limits=servo)
    w.joint("fixed", tilt, w.link())
    return w.urdf(), forearms, jaws


def test_a_small_humanoids_arms_are_no_fingers_and_end_in_no_tool():
    """A small humanoid of hobby servos, every joint turning +-2.8 rad: its arms are as short as a large hand's
    fingers, so its trunk was read as a palm and each forearm became a one-finger gripper (or, with the hand gone, a
    gyroscope). Fingers reach less than half as far as the legs the robot stands on, and no jaw nor sensor ends a
    limb on a joint turning through more than half a turn: the forearms are the arms' own. With bounded ranges the
    forearms are left to the model; jaws of 3 cm on them make two grippers."""
    urdf, forearms, _ = _servo_humanoid(13, (-2.8, 2.8))
    tree = load_urdf(urdf)
    assert len(feet(tree)) == 2 and hands(tree) == [] and set(forearms) <= limb_ends(tree)
    erring = {TAX.answer(TOOL_CLS): 0.5, TAX.answer(SENSOR_CLS): 0.3, NONE: 0.2}
    claims = _identified(urdf, lambda q: erring if _leaf(q) in forearms else NONE)
    assert [claims[f] for f in forearms] == [NONE, NONE]
    urdf, forearms, _ = _servo_humanoid(13, (-1.5, 1.5))
    tree = load_urdf(urdf)
    assert hands(tree) == [] and not set(forearms) & limb_ends(tree)
    claims = _identified(urdf, lambda q: erring if _leaf(q) in forearms else NONE)
    assert [claims[f] for f in forearms] == [TOOL_CLS, TOOL_CLS]
    urdf, _, jaws = _servo_humanoid(13, (-2.8, 2.8), grippers=True)
    assert sorted(leaf for _, leaves in hands(load_urdf(urdf)) for leaf in leaves) == sorted(jaws)


@pytest.mark.parametrize("hanging", [False, True])
def test_a_servo_robots_range_says_nothing_of_the_jaw_ending_its_arm(hanging):
    """A small humanoid's file gives every servo +-2.09 rad; each leg of six joints ends in a foot, each arm of four in
    a one-link jaw on a fifth, its mass near its hinge. That range, the same on every joint of the limb, says nothing of what the last one
    moves: the jaw does not roll, and the model's "end effector" stands (on the code before: the jaw rolled, so no
    tool, and both grippers were lost). A forearm whose mass hangs out along the arm is a segment of it still."""
    servo = (-2.09, 2.09)
    w = Writer(random.Random(17))
    trunk = w.link('<box size="0.1 0.15 0.12"/>')
    ends = []
    for y in (0.08, -0.08):
        link = trunk
        for k in range(6):  # a leg it stands on
            child = w.link('<box size="0.03 0.03 0.04"/>')
            w.joint("revolute", link, child, (0.0, y / 2, -0.06) if k == 0 else (0.0, 0.0, -0.05),
                    (0.0, 0.0, 1.0) if k == 0 else (0.0, 1.0, 0.0), limits=servo)
            link = child
        link = trunk
        for k in range(5):
            last = k == 4
            centre = (0.0, 0.0, -0.06) if last and hanging else (0.0, 0.0, -0.005) if last else None
            child = w.link('<box size="0.02 0.02 0.03"/>' if last else '<box size="0.03 0.03 0.07"/>', centre=centre)
            w.joint("revolute", link, child, (0.0, y, 0.05) if k == 0 else (0.0, 0.0, -0.07),
                    (0.0, 1.0, 0.0) if k % 2 == 0 else (1.0, 0.0, 0.0), limits=servo)
            link = child
        ends.append(link)
    tree = load_urdf(w.urdf())
    assert all(rolling(tree, end) == hanging for end in ends)
    erring = {TAX.answer(TOOL_CLS): 0.5, TAX.answer(SENSOR_CLS): 0.3, NONE: 0.2}
    claims = _identified(w.urdf(), lambda q: erring if _leaf(q) in ends else NONE)
    assert [claims[end] for end in ends] == [NONE if hanging else TOOL_CLS] * 2


def test_a_jaw_on_a_joint_with_no_range_ends_its_arm_where_no_joint_of_the_file_has_one():
    """SolidWorks' exporter writes every joint 0..0 unless told: an arm of four joints so written, ending in a jaw
    on a fifth. No joint of the file has a range, so the limits say nothing: the jaw ends a limb, and the erring
    model's "sensor" (0.6) gives way to its next answer, a tool (on the code before: a sensor). Where another joint
    of the file has a range, a joint with none still moves nothing (test above: the force sensor's frame)."""
    for ranged in (False, True):
        w = Writer(random.Random(21))
        trunk = w.link('<box size="0.3 0.3 0.4"/>')
        jaw = w.link('<box size="0.02 0.01 0.06"/>')
        w.joint("revolute", _serial(w, trunk, 4, (0.0, 0.0)), jaw, (0.02, 0.0, 0.1), (0.0, 1.0, 0.0), limits=(0.0, 0.0))
        if ranged:  # a pan joint elsewhere with a range
            w.joint("revolute", trunk, w.link('<box size="0.05 0.05 0.05"/>'), (0.0, 0.0, 0.3), limits=(-1.0, 1.0))
        tree = load_urdf(w.urdf())
        assert (jaw in limb_ends(tree)) == (not ranged)
        options = {TAX.answer(SENSOR_CLS): 0.6, TAX.answer(TOOL_CLS): 0.3, NONE: 0.1}
        claims = _identified(w.urdf(), lambda q: options if _leaf(q) == jaw else NONE)
        assert claims[jaw] == (SENSOR_CLS if ranged else TOOL_CLS), ranged


@pytest.mark.parametrize("mesh", ["suction_cup", "end_part"])
def test_a_limb_end_turning_past_half_a_turn_is_a_tool_where_it_names_a_tool_product(mesh):
    """A small arm's last link turns on a servo through 300 degrees: it rolls, as a flange does, so it is no tool by
    its place; but where its mesh names a tool product of the catalogue (a suction cup, the generic kind), it is a
    tool wherever it ends, and the erring model's "sensor" (0.78) gives way to "end effector" (0.16), not to none
    (on the code before: none, the cup missed)."""
    w = Writer(random.Random(23))
    base = w.link('<cylinder radius="0.08" length="0.1"/>')
    end = w.link(f'<mesh filename="package://kit/meshes/{mesh}.dae"/>')
    w.joint("revolute", _serial(w, base, 3, (-1.5, 1.5)), end, (0.05, 0.0, -0.05), limits=(-2.618, 2.618))
    tree = load_urdf(w.urdf())
    assert end in limb_ends(tree) and rolling(tree, end)
    erring = {TAX.answer(SENSOR_CLS): 0.78, TAX.answer(TOOL_CLS): 0.16, NONE: 0.06}
    claims = _identified(w.urdf(), lambda q: erring if _leaf(q) == end else NONE)
    assert claims[end] == (TOOL_CLS if mesh == "suction_cup" else NONE)


@pytest.mark.parametrize("centre", [None, (0.0, 0.0, 0.0)])
def test_a_camera_balanced_at_the_end_of_a_gimbal_is_a_sensor(centre):
    """A drone's camera is the last link of a three-joint gimbal whose pitch turns 4.1 rad, past half a turn as a
    servo robot's elbow does; but a gimbal balances its camera on its axes (or the file gives no mass to say
    otherwise), so it is no limb's last segment, and the model's "sensor" (0.9) stands."""
    w = Writer(random.Random(17))
    body = w.link('<box size="0.2 0.1 0.06"/>')
    for x, y in ((0.1, 0.15), (0.1, -0.15), (-0.14, 0.12), (-0.14, -0.12)):
        w.joint("continuous", body, w.link('<cylinder radius="0.1" length="0.01"/>'), (x, y, 0.0))
    yaw, roll = w.link('<box size="0.02 0.02 0.03"/>'), w.link('<box size="0.03 0.02 0.02"/>')
    camera = w.link('<box size="0.04 0.05 0.04"/>', centre=centre)
    w.joint("revolute", body, yaw, (0.09, 0.0, -0.04), limits=(-0.47, 0.47))
    w.joint("revolute", yaw, roll, (-0.015, 0.0, -0.03), (1.0, 0.0, 0.0), limits=(-0.79, 0.79))
    w.joint("revolute", roll, camera, (0.034, 0.0, 0.0), (0.0, 1.0, 0.0), limits=(-1.75, 2.36))
    urdf = w.urdf()
    assert camera not in limb_ends(load_urdf(urdf))
    claims = _identified(urdf, lambda q: {TAX.answer(SENSOR_CLS): 0.9, NONE: 0.1} if _leaf(q) == camera else NONE)
    assert claims[camera] == SENSOR_CLS


def _forearm_arms(seed: int, centre: float | None) -> tuple[bytes, list[str], str]:
    """A trunk with two arms of four joints held out sideways (two at the shoulder, one turning the upper arm, the
    elbow) whose forearms, 0.25 m long, hang alone from the elbow with their centre of mass `centre` out along them
    (no <inertial> where None), every joint turning +-1.3 rad; and an arm of six joints, 0.6 m, ending in a lone jaw
    of 6 cm whose centre of mass lies 2 cm out. The forearms and the jaw."""
    rng = random.Random(seed)
    w = Writer(rng)
    trunk = w.link('<box size="0.2 0.3 0.4"/>', centre=(0.0, 0.0, 0.0), mass=5.0)
    forearms = []
    for side in (1.0, -1.0):
        shoulder = w.link('<box size="0.04 0.04 0.04"/>', centre=(0.0, 0.0, 0.0))
        w.joint("revolute", trunk, shoulder, (0.0, side * 0.18, 0.15), (0.0, 1.0, 0.0), (-1.3, 1.3))
        upper = w.link('<box size="0.04 0.04 0.04"/>', centre=(0.0, side * 0.02, 0.0))
        w.joint("revolute", shoulder, upper, (0.0, side * 0.05, 0.0), (1.0, 0.0, 0.0), (-1.3, 1.3))
        turning = w.link('<box size="0.04 0.25 0.04"/>', centre=(0.0, side * 0.12, 0.0))
        w.joint("revolute", upper, turning, (0.0, side * 0.05, 0.0), (0.0, 1.0, 0.0), (-1.3, 1.3))
        forearm = w.link('<box size="0.04 0.25 0.04"/>', centre=None if centre is None else (0.0, side * centre, 0.0))
        w.joint("revolute", turning, forearm, (0.0, side * 0.25, 0.0), (0.0, 0.0, 1.0), (-rng.uniform(1.2, 1.3), 1.3))
        forearms.append(forearm)
    wrist = _serial(w, trunk, 4)  # 0.6 m of arm, six joints to the jaw's
    jaw = w.link('<box size="0.02 0.01 0.06"/>', centre=(0.0, 0.0, 0.02))
    w.joint("revolute", wrist, jaw, (0.02, 0.0, 0.1), (0.0, 1.0, 0.0), limits=(-1.57, 0.0))
    return w.urdf(), forearms, jaw


@pytest.mark.parametrize("seed", range(4))
def test_a_forearm_that_ends_an_arm_is_no_tool_a_lone_jaw_is(seed):
    """Arms that end in no tool: the elbow turns the forearm through a bounded arc, as a jaw turns, and the erring
    model calls each forearm an end effector at 0.5 (they became one-finger grippers). A forearm carries its mass a
    third of its arm's length out (here 0.12 of 0.35 m from the elbow); a jaw, small beside the arm that carries it, a
    few centimetres (2 of 60 cm; 3 of 80 on an arm written folded back, its pin 8 cm from its base): the forearms are
    the arms' own, the jaw stays the model's tool. Where the file gives
    a forearm no <inertial>, nothing says how far its mass lies: the model decides."""
    urdf, forearms, jaw = _forearm_arms(seed, 0.12)
    tree = load_urdf(urdf)
    assert not feet(tree) and not hands(tree)
    assert {*forearms, jaw} <= limb_ends(tree) and not any(rolling(tree, leaf) for leaf in (*forearms, jaw))
    assert last_segments(tree, limb_ends(tree)) == set(forearms)
    erring = {TAX.answer(TOOL_CLS): 0.5, TAX.answer(SENSOR_CLS): 0.3, NONE: 0.2}
    claims = _identified(urdf, lambda q: erring if _leaf(q) in (*forearms, jaw) else NONE)
    assert not {claims[f] for f in forearms} & {TOOL_CLS, SENSOR_CLS} and claims[jaw] == TOOL_CLS
    folded = Writer(random.Random(seed))  # the same jaw's arm written folded back on itself: as long as ever
    link = folded.link('<box size="0.2 0.2 0.2"/>')
    for out in (0.2, 0.2, -0.18, -0.18, 0.02, 0.02):  # 0.8 m of links, the jaw's pin 8 cm from the base
        child = folded.link('<box size="0.05 0.05 0.15"/>')
        folded.joint("revolute", link, child, (0.0, 0.0, out), (0.0, 1.0, 0.0), (-2.0, 2.0))
        link = child
    tip = folded.link('<box size="0.02 0.01 0.06"/>', centre=(0.0, 0.0, 0.03))
    folded.joint("revolute", link, tip, (0.02, 0.0, 0.02), (0.0, 1.0, 0.0), limits=(-1.57, 0.0))
    tree = load_urdf(folded.urdf())
    assert tip in limb_ends(tree) and not last_segments(tree, limb_ends(tree))
    urdf, forearms, jaw = _forearm_arms(seed, None)
    assert not last_segments(load_urdf(urdf), limb_ends(load_urdf(urdf)))
    claims = _identified(urdf, lambda q: erring if _leaf(q) in (*forearms, jaw) else NONE)
    assert [claims[f] for f in forearms] == [TOOL_CLS, TOOL_CLS]


@pytest.mark.parametrize("seed", range(4))
def test_a_thin_rod_is_no_sensor(seed):
    """A mobile base whose stack is held by thin poles (cylinders of 12 mm, as long as the gap they span) and with an
    antenna; the erring model calls each pole and the antenna a sensor at 0.6 (a depth camera's poles, named after
    the camera they hold, became two RGB-D cameras). A rod holds no sensing element: none is a sensor. A camera in a
    squat cylinder, a sonar in a short thin one (2 cm across, 3 cm long) and a stereo camera drawn as a cylinder 3 cm
    across and 17 cm long stay the model's sensors."""
    rng = random.Random(seed)
    w = Writer(rng)
    base = w.link('<cylinder radius="0.18" length="0.1"/>')
    poles = []
    for k in range(4):
        poles.append(w.link(f'<cylinder radius="0.006" length="{rng.uniform(0.06, 0.2):.3f}"/>'))
        w.joint("fixed", base, poles[-1], (0.1 * math.cos(k * 1.57), 0.1 * math.sin(k * 1.57), 0.1))
    antenna = w.link('<cylinder radius="0.004" length="0.15"/>')
    w.joint("fixed", base, antenna, (-0.1, 0.05, 0.1))
    camera = w.link('<cylinder radius="0.03" length="0.05"/>')
    w.joint("fixed", base, camera, (0.15, 0.0, 0.2))
    sonar = w.link('<cylinder radius="0.01" length="0.03"/>')
    w.joint("fixed", base, sonar, (0.18, 0.05, 0.05))
    stereo = w.link('<cylinder radius="0.015" length="0.17"/>')
    w.joint("fixed", base, stereo, (0.18, -0.05, 0.25))
    tree = load_urdf(w.urdf())
    assert rods(tree) == {*poles, antenna}
    sensor = {TAX.answer(SENSOR_CLS): 0.6, NONE: 0.4}
    claims = _identified(w.urdf(), lambda q: sensor)
    assert {claims[leaf] for leaf in (*poles, antenna)} == {NONE}
    assert claims[camera] == claims[sonar] == claims[stereo] == SENSOR_CLS


def test_a_leaf_spinning_from_the_trunk_is_no_tool():
    """An underwater vehicle's thrusters (or a drone's rotors) spin on continuous joints from the hull: the erring model
    calls each an end effector at 0.5 (eight thrusters became one hand of eight tool frames). No tool spins there; a
    gripper's own drive screw, spinning below the arm's joints, and a jaw on a bounded hinge stay the model's tools."""
    for seed in range(5):
        w = Writer(random.Random(seed))
        hull = w.link('<box size="0.5 0.3 0.2"/>')
        thrusters = []
        for k in range(6):
            thruster = w.link('<cylinder radius="0.04" length="0.03"/>')
            yaw = k * math.pi / 3
            w.joint("continuous", hull, thruster, (0.25 * math.cos(yaw), 0.15 * math.sin(yaw), 0.0), (1.0, 0.0, 0.0))
            thrusters.append(thruster)
        screw, jaw = _gripper_with_screw(w, hull)
        tree = load_urdf(w.urdf())
        assert spinning_on_trunk(tree) == set(thrusters), seed
        erring = {TAX.answer(TOOL_CLS): 0.5, TAX.answer(SENSOR_CLS): 0.2, NONE: 0.3}
        claims = _identified(w.urdf(), lambda q: erring)
        assert {claims[t] for t in thrusters} == {NONE}, seed
        assert claims[screw] == claims[jaw] == TOOL_CLS, seed


@pytest.mark.parametrize("seed", range(5))
def test_wheels_on_steering_joints_and_bogies_are_no_tools(seed):
    """A rover's six wheels each spin below a steering joint on a rocking bogie: not on the trunk, yet the erring
    model calls each an end effector at 0.5. Leaves spinning in the lowest third of the robot are wheels, never tools;
    the drive screw spinning in the gripper of the arm the rover carries stays the model's tool."""
    w = Writer(random.Random(seed))
    chassis = w.link('<box size="0.6 0.4 0.1"/>')
    wheels = []
    for side in (1.0, -1.0):
        bogie = w.link('<box size="0.4 0.04 0.04"/>')
        w.joint("revolute", chassis, bogie, (0.0, side * 0.25, -0.05), (0.0, 1.0, 0.0), limits=(-0.4, 0.4))
        for x in (-0.2, 0.0, 0.2):
            steer, wheel = w.link('<box size="0.03 0.03 0.08"/>'), w.link('<cylinder radius="0.06" length="0.04"/>')
            w.joint("revolute", bogie, steer, (x, side * 0.05, -0.05), (0.0, 0.0, 1.0), limits=(-1.57, 1.57))
            w.joint("continuous", steer, wheel, (0.0, 0.0, -0.08), (0.0, 1.0, 0.0))
            wheels.append(wheel)
    screw, jaw = _gripper_with_screw(w, chassis)
    tree = load_urdf(w.urdf())
    assert spinning_on_trunk(tree) == frozenset() and spinning_low(tree) == set(wheels)
    erring = {TAX.answer(TOOL_CLS): 0.5, TAX.answer(SENSOR_CLS): 0.2, NONE: 0.3}
    claims = _identified(w.urdf(), lambda q: erring)
    assert TOOL_CLS not in {claims[wheel] for wheel in wheels} and claims[screw] == claims[jaw] == TOOL_CLS


def _gripper_with_screw(w: Writer, base: str) -> tuple[str, str]:
    """An arm of four joints on `base` ending in a gripper's drive screw, spinning, and a jaw on a bounded hinge."""
    wrist = _serial(w, base, 4, (-2.0, 2.0))
    screw, jaw = w.link('<cylinder radius="0.005" length="0.04"/>'), w.link('<box size="0.02 0.01 0.06"/>')
    w.joint("continuous", wrist, screw, (0.0, 0.0, 0.05), (0.0, 0.0, 1.0))
    w.joint("revolute", wrist, jaw, (0.02, 0.0, 0.05), (0.0, 1.0, 0.0), limits=(-0.5, 0.0))
    return screw, jaw


def _fixed_chains(w: Writer, parent: str, size: str) -> list[str]:
    """Four chains of three boxes of `size` fixed in series on `parent`, side by side; their tips."""
    tips = []
    for k in range(4):
        link = parent
        for _ in range(3):
            child = w.link(f'<box size="{size}"/>')
            w.joint("fixed", link, child, (0.02 * k - 0.03, 0.0, 0.03) if link == parent else (0.0, 0.0, 0.03))
            link = child
        tips.append(link)
    return tips


def _frozen_hand(w: Writer) -> tuple[str, list[str]]:
    """A base, an arm of six joints, and on it a palm with four fingers written fixed; the base and the fingertips."""
    base = w.link('<box size="0.4 0.3 0.2"/>')
    palm = w.link('<box size="0.08 0.1 0.02"/>')
    w.joint("revolute", _serial(w, base, 5), palm, (0.0, 0.0, 0.1))
    return base, _fixed_chains(w, palm, "0.015 0.015 0.03")


def test_the_fingertips_of_a_hand_written_fixed_are_no_sensors():
    """A hand whose finger joints are all written fixed (an export that froze them): four chains of three bodies
    from a palm at an arm's end. The erring model calls each tip a touch sensor at 0.6: a finger is no sensor, so
    the model's next answer stands. Standoffs stacked on a mobile base have the shape, but no limb carries them."""
    w = Writer(random.Random(7))
    base, tips = _frozen_hand(w)
    stack_base = w.link('<box size="0.3 0.3 0.05"/>')
    w.joint("fixed", base, stack_base, (0.0, 0.0, -0.2))
    stacks = _fixed_chains(w, stack_base, "0.01 0.01 0.05")
    tree = load_urdf(w.urdf())
    assert frozen_fingertips(tree) == set(tips)
    erring = {TAX.answer(SENSOR_CLS): 0.6, TAX.answer(TOOL_CLS): 0.3, NONE: 0.1}
    claims = _identified(w.urdf(), lambda q: erring if _leaf(q) in tips + stacks else NONE)
    assert {leaf: claims[leaf] for leaf in tips} == dict.fromkeys(tips, TOOL_CLS)
    assert {leaf: claims[leaf] for leaf in stacks} == dict.fromkeys(stacks, SENSOR_CLS)


def _run_calling_sensors(w: Writer, leaves: list[str]) -> tuple[dict[str, Question], Abstraction]:
    """The whole pipeline over `w`'s robot with a scripted model that identifies `leaves` as sensors at 0.6 (a tool
    0.3), every other leaf as none, and answers every other question with its first option; the questions asked
    by key, and the result."""
    from tests.scripted_reasoner import scripted_reasoner
    from urdfkb.pipeline import runner
    asked: dict[str, Question] = {}

    def erring(q: Question):
        asked[q.key] = q
        if q.key.startswith("identify:"):
            return {TAX.answer(SENSOR_CLS): 0.6, TAX.answer(TOOL_CLS): 0.3, NONE: 0.1} if _leaf(q) in leaves else NONE
        return q.options[0]
    result = runner.run(load_urdf(w.urdf()), runner.Settings(use_cache=False), backend=ScriptedBackend(erring),
                        reasoner=scripted_reasoner)
    return asked, result


def test_a_hand_written_fixed_is_asked_about_as_one_with_fingers():
    """The frozen hand of the test above, through the whole pipeline with a scripted model that calls every
    fingertip a sensor at 0.6: the tips go to one end effector, whose kind is asked with its structure said as
    "4 fingers written fixed" and without the rigid tool (a probe, a ball) among the answers."""
    w = Writer(random.Random(7))
    _, tips = _frozen_hand(w)
    asked, _ = _run_calling_sensors(w, tips)
    post = [q for key, q in asked.items() if key.startswith("post:") and key.endswith("@EndEffector")]
    assert len(post) == 1 and "Structure: 4 fingers written fixed" in post[0].user
    assert "rigid tool" not in post[0].options
    fingers = {link for tip in tips for link in load_urdf(w.urdf()).chain_to_root(tip)[:3]}
    parts = {key.split(":", 1)[1].split("@")[0]: q.options for key, q in asked.items() if key.startswith("part:")}
    assert fingers <= set(parts)  # each finger link asked its role, as a finger or its contact surface, no palm
    assert all(TAX.answer("Palm") not in parts[link] for link in fingers), {k: parts[k] for k in fingers}


def _frozen_gripper(w: Writer) -> tuple[list[str], str, list[str]]:
    """A base, an arm of six joints, and on its wrist a gripper written fixed: two jaws of three boxes each, mirror
    images across the wrist's x-z plane, a one-box bar beside each, and a box alone on the wrist (a camera's body);
    on the base a pan-tilt head with two eyes of two boxes each, mirror images too. The jaws' tips and bars, the
    lone box, the eyes' tips."""
    base = w.link('<box size="0.4 0.3 0.2"/>')
    wrist = w.link('<box size="0.06 0.06 0.02"/>')
    w.joint("revolute", _serial(w, base, 5), wrist, (0.0, 0.0, 0.1))
    parts = []
    for side in (1.0, -1.0):
        link = wrist
        for k in range(3):
            child = w.link('<box size="0.01 0.02 0.03"/>')
            w.joint("fixed", link, child, (0.0, side * 0.03, 0.03) if k == 0 else (0.0, -side * 0.005, 0.03))
            link = child
        bar = w.link('<box size="0.01 0.01 0.04"/>')
        w.joint("fixed", wrist, bar, (0.0, side * 0.015, 0.05))
        parts += [link, bar]
    lone = w.link('<box size="0.02 0.03 0.02"/>')
    w.joint("fixed", wrist, lone, (0.04, 0.0, 0.0))
    head = _serial(w, base, 2)
    eyes = []
    for side in (1.0, -1.0):
        mount, eye = w.link('<box size="0.02 0.02 0.02"/>'), w.link('<box size="0.03 0.02 0.02"/>')
        w.joint("fixed", head, mount, (0.05, side * 0.04, 0.0))
        w.joint("fixed", mount, eye, (0.02, 0.0, 0.0))
        eyes.append(eye)
    return parts, lone, eyes


def test_the_jaws_of_a_gripper_written_fixed_are_no_sensors():
    """A gripper whose jaw joints are all written fixed (a description that froze them): two chains of three bodies
    mirror images of each other at an arm's end, a bar beside each, are its fingers; a lone body beside them may be
    a camera, and two eyes on a pan-tilt head (no limb) are no jaws. The erring model calls each a touch sensor at
    0.6 (a humanoid's claws became eight tactile sensors): a finger is no sensor, so the model's next answer stands."""
    w = Writer(random.Random(11))
    parts, lone, eyes = _frozen_gripper(w)
    tree = load_urdf(w.urdf())
    assert frozen_fingertips(tree) == set(parts)
    erring = {TAX.answer(SENSOR_CLS): 0.6, TAX.answer(TOOL_CLS): 0.3, NONE: 0.1}
    claims = _identified(w.urdf(), lambda q: erring if _leaf(q) in parts + eyes + [lone] else NONE)
    assert {leaf: claims[leaf] for leaf in parts} == dict.fromkeys(parts, TOOL_CLS)
    assert {leaf: claims[leaf] for leaf in eyes + [lone]} == dict.fromkeys(eyes + [lone], SENSOR_CLS)


def test_mirrored_sensors_beside_a_moving_gripper_or_on_a_head_beside_arms_are_no_jaws():
    """Two mirrored sensors of two bodies each, on the wrist a moving gripper hangs from, or on a head whose neck
    starts where the arms do (its four joints are the trunk's and the neck's, not one limb's): no gripper written
    fixed, so the model's 'sensor' stands for them."""
    w = Writer(random.Random(4))
    base = w.link('<box size="0.4 0.3 0.2"/>')
    wrist = _serial(w, base, 6)
    jaw = w.link('<box size="0.01 0.02 0.04"/>')
    w.joint("prismatic", wrist, jaw, (0.0, 0.02, 0.1), (0.0, 1.0, 0.0), limits=(0.0, 0.03))
    chest = _serial(w, base, 2)
    for _ in range(2):
        _serial(w, chest, 4)  # an arm on either side of the neck
    head = _serial(w, chest, 2)
    for body in (wrist, head):
        for side in (1.0, -1.0):
            mount, sensor = w.link('<box size="0.02 0.02 0.02"/>'), w.link('<box size="0.03 0.02 0.02"/>')
            w.joint("fixed", body, mount, (0.05, side * 0.04, 0.0))
            w.joint("fixed", mount, sensor, (0.02, 0.0, 0.0))
    tree = load_urdf(w.urdf())
    assert frozen_fingertips(tree) == frozenset()


def test_a_gripper_written_fixed_is_asked_about_as_jaws():
    """The frozen gripper of the test above, through the whole pipeline with a scripted model that calls its parts
    sensors at 0.6: they go to one end effector, whose kind is asked with its structure said as jaws facing each
    other (a count of fingers made a humanoid's claw grippers hands), without the rigid tool among the answers."""
    w = Writer(random.Random(11))
    parts, _, _ = _frozen_gripper(w)
    asked, result = _run_calling_sensors(w, parts)
    post = [q for key, q in asked.items() if key.startswith("post:") and key.endswith("@EndEffector")]
    assert len(post) == 1 and "Structure: jaws written fixed, facing each other in mirror-image pairs" in post[0].user
    assert "rigid tool" not in post[0].options
    tools = [c for c in result.components if c.kind == "end_effector"]
    assert len(tools) == 1 and set(parts) <= {s.link for s in tools[0].subcomponents}


def _collision_only(w: Writer, parent: str, geometry: str, xyz=(0.0, 0.0, 0.0)) -> str:
    """A leaf fixed to `parent` at `xyz` with `geometry` as its <collision> and no <visual>."""
    name = w.link(collision=geometry)
    w.joint("fixed", parent, name, xyz)
    return name


@pytest.mark.parametrize("seed", range(5))
def test_collision_volumes_at_their_parents_origin_are_no_component_and_not_asked(seed):
    """An arm whose links each carry a self-collision capsule, a leaf fixed at the link's origin with collision
    geometry alone: the erring model calls every leaf a sensor at 0.7 (a dual arm's capsules became tactile and
    force-torque sensors). They are more of their links' bodies: no component, not asked. A small pad drawn for
    collision alone away from its link's origin (a foot's pressure sensor), a leaf drawn to be seen at its link's
    origin, and a leaf drawn for collision alone at the origin of a bare mount frame are asked as ever."""
    w = Writer(random.Random(seed))
    base = w.link('<cylinder radius="0.1" length="0.2"/>')
    link, capsules = base, []
    for i in range(random.Random(seed).randint(4, 7)):
        child = w.link('<box size="0.05 0.05 0.15"/>')
        w.joint("revolute", link, child, (0.0, 0.0, 0.15), (0.0, 0.0, 1.0) if i % 2 == 0 else (0.0, 1.0, 0.0))
        capsules.append(_collision_only(w, child, '<cylinder radius="0.06" length="0.2"/>'))
        link = child
    pad = _collision_only(w, base, '<box size="0.01 0.01 0.005"/>', (0.05, 0.03, -0.1))
    seen = w.link('<box size="0.03 0.03 0.03"/>')  # drawn to be seen, at its link's origin
    w.joint("fixed", base, seen)
    mount = w.link()  # a bare mount frame, and a device drawn for collision alone at its origin
    w.joint("fixed", base, mount, (0.1, 0.0, 0.1))
    device = _collision_only(w, mount, '<cylinder radius="0.03" length="0.04"/>')
    tree = load_urdf(w.urdf())
    assert collision_volumes(tree) == set(capsules)
    asked = []

    def erring(q):
        asked.append(_leaf(q))
        return {TAX.answer(SENSOR_CLS): 0.7, NONE: 0.3}
    claims = _identified(w.urdf(), erring)
    assert {claims[c] for c in capsules} == {NONE} and not set(capsules) & set(asked)
    assert all(claims[leaf] == SENSOR_CLS and leaf in asked for leaf in (pad, seen, device))


def _rover(seed: int, fenders: bool = False) -> tuple[bytes, list[str]]:
    """A low rover on four mirrored corner modules, each a steering joint carrying a wheel whose drive the file
    writes revolute with a wide range; with `fenders`, a sliding suspension under the steering joint carries the wheel
    (continuous) and a fender fixed beside it."""
    w = Writer(random.Random(seed))
    trunk = w.link('<box size="0.8 0.5 0.1"/>')
    wheels = []
    for x in (0.35, -0.35):
        for y in (0.3, -0.3):
            fork, wheel = w.link('<box size="0.05 0.05 0.1"/>'), w.link('<cylinder radius="0.06" length="0.05"/>')
            w.joint("revolute", trunk, fork, (x, y, 0.0), limits=(-1.5, 1.5))
            if fenders:
                spring = w.link('<box size="0.04 0.04 0.04"/>')
                w.joint("prismatic", fork, spring, (0.0, 0.0, -0.02), limits=(-0.03, 0.03))
                w.joint("continuous", spring, wheel, (0.0, 0.12 if y > 0 else -0.12, -0.12), (0.0, 1.0, 0.0))
                w.joint("fixed", spring, w.link('<box size="0.25 0.06 0.02"/>'), (0.0, 0.12 if y > 0 else -0.12, 0.0))
            else:
                w.joint("revolute", fork, wheel, (0.0, 0.12 if y > 0 else -0.12, -0.12), (0.0, 1.0, 0.0), (-1e4, 1e4))
            wheels.append(wheel)
    return w.urdf(), wheels


def test_no_feet_where_no_legs_are_even_level_with_the_trunk():
    """Where nothing stands below the trunk, feet are the tips of legs leaving it in mirrored pairs spread front to
    back (test_body_pass: test_legs_the_zero_pose_holds_out_level_are_legs); a rover's corner wheel modules (a fender
    fixed beside the wheel), the fingers of a hand published alone, in a row, and fingers in a square pointing up
    are no feet."""
    for seed in range(8):
        for fenders in (False, True):
            urdf, wheels = _rover(seed, fenders)
            tree = load_urdf(urdf)
            assert all(rolling(tree, wheel) for wheel in wheels) and not feet(tree), (seed, fenders)
    for seed in SEEDS:
        tree = load_urdf(build(seed, alone=True).urdf)
        assert not feet(tree), seed
    w = Writer(random.Random(4))  # four fingers in a square on a palm, pointing up: no limb comes down
    palm = w.link('<box size="0.1 0.1 0.02"/>')
    for x in (0.03, -0.03):
        for y in (0.03, -0.03):
            parent, xyz = palm, (x, y, 0.02)
            for _ in range(2):
                child = w.link('<box size="0.01 0.01 0.05"/>')
                w.joint("revolute", parent, child, xyz, (0.0, 1.0, 0.0), (0.0, 1.0))
                parent, xyz = child, (0.0, 0.0, 0.05)
            w.joint("fixed", parent, w.link(), (0.0, 0.0, 0.05))
    assert not feet(load_urdf(w.urdf()))


def _small_quadruped(seed: int) -> tuple[bytes, list[str], str]:
    """A quadruped 0.2 m long standing 0.1 m tall (legs of three joints hanging down, a foot fixed at each tip), a
    bare toe frame fixed on one leg's last link above its foot; names meaningless. The URDF, the feet, the toe."""
    w = Writer(random.Random(seed))
    trunk = w.link('<box size="0.2 0.1 0.05"/>')
    feet_, toe = [], ""
    for x in (0.06, -0.06):
        for y in (0.03, -0.03):
            parent = trunk
            for i, xyz in enumerate(((x, y, 0.0), (0.0, 0.02 if y > 0 else -0.02, 0.0), (0.0, 0.0, -0.05))):
                child = w.link('<box size="0.01 0.01 0.05"/>')
                w.joint("revolute", parent, child, xyz, (1.0, 0.0, 0.0) if not i else (0.0, 1.0, 0.0))
                parent = child
            foot = w.link('<sphere radius="0.008"/>')
            w.joint("fixed", parent, foot, (0.0, 0.0, -0.05))
            feet_.append(foot)
            if not toe:
                toe = w.link()
                w.joint("fixed", parent, toe, (0.02, 0.0, -0.03))
    return w.urdf(), feet_, toe


@pytest.mark.parametrize("seed", range(4))
def test_a_small_quadrupeds_legs_are_legs_not_a_hands_fingers_and_its_feet_carry_no_tool(seed):
    """A quadruped too small to stand STANCE tall (0.1 m) had its four legs read as the fingers of a hand on its
    trunk (one anthropomorphic hand at 1.00): its legs leave the trunk in mirrored pairs spread front to back,
    so their tips are feet, and a frame on a foot's body the model calls an end effector (a humanoid's toe frames made
    its legs no legs) is no tool."""
    urdf, tips, toe = _small_quadruped(seed)
    tree = load_urdf(urdf)
    assert feet(tree) == set(tips) and not hand_leaves(tree)

    def erring(q):
        return TAX.answer(TOOL_CLS) if _leaf(q) == toe else NONE
    assert _identified(urdf, erring)[toe] != TOOL_CLS


@pytest.mark.parametrize("seed", range(0, 60, 3))
def test_a_robot_fixed_to_a_world_frame_on_the_floor_still_stands_on_its_feet(seed):
    """The same legged robot with its trunk fixed to a bare `world` frame at the floor below it (files do so to
    hang a humanoid in a simulator): its feet are the same leg tips, as when its trunk is the root."""
    built = legged(seed)
    tree = load_urdf(built.urdf)
    lowest = min(tree.position_in(link, tree.root)[2] for link in tree.links)
    text = built.urdf.decode()
    at = text.index("<link ")
    hung = (text[:at] + '<link name="world"/><joint name="world_fixed" type="fixed"><parent link="world"/>'
            f'<child link="{tree.root}"/><origin xyz="0 0 {-lowest}" rpy="0 0 0"/></joint>' + text[at:]).encode()
    standing = load_urdf(hung)
    assert standing.root == "world" and feet(standing) == feet(tree) == _leg_tips(built, tree)


@pytest.mark.parametrize("seed", range(3))
def test_contact_sensors_declared_on_a_wheeled_trunk_are_sensors_and_elsewhere_left_to_the_model(seed):
    """A Gazebo contact sensor declared on a panel fixed to the trunk of a robot on wheels (a bumper) says the panel
    is a sensor, whatever the model thinks; declared on a legged robot's trunk (a skid it lands on) or foot, it also
    reports touching the ground, so the model decides there."""
    for make in (wheeled, legged):
        built = make(seed)
        tree = load_urdf(built.urdf)
        foot = sorted(_leg_tips(built, tree))[0] if make is legged else None
        panel = ('<link name="panel"><collision><geometry><box size="0.01 0.25 0.05"/></geometry></collision></link>'
                 f'<joint name="panel_joint" type="fixed"><parent link="{tree.root}"/><child link="panel"/>'
                 '<origin xyz="0.3 0 0" rpy="0 0 0"/></joint>')
        declared = "".join(f'<gazebo reference="{link}"><sensor name="{link}_contact" type="contact"><contact>'
                           f'<collision>{link}_collision</collision></contact></sensor></gazebo>'
                           for link in ("panel", foot) if link)
        urdf = built.urdf.decode().replace("</robot>", panel + declared + "</robot>").encode()
        claims = _identified(urdf, lambda q: "none" if "none" in q.options else q.options[-1])
        sensor = TAX.kinds["sensor"].cls
        assert (claims["panel"] == sensor) == (make is wheeled), (make.__name__, seed)
        assert foot is None or claims.get(foot) != sensor


def test_the_swivel_casters_of_a_base_on_a_footprint_frame_are_no_feet():
    """A wheeled base fixed 0.2 m above a bare footprint frame on the floor, on two drive wheels and two swivel
    casters (a continuous swivel carrying a continuous wheel, its centre 3 cm up): the casters' wheels roll, they
    are no feet (so a gripper's fingers on its arm are measured against no legs)."""
    w = Writer(random.Random(4))
    footprint, base = w.link(), w.link('<box size="0.5 0.4 0.15"/>')
    w.joint("fixed", footprint, base, (0.0, 0.0, 0.2))
    for y in (0.2, -0.2):
        w.joint("continuous", base, w.link('<cylinder radius="0.1" length="0.04"/>'), (0.0, y, -0.1), (0, 1, 0))
        swivel, wheel = w.link('<box size="0.02 0.02 0.1"/>'), w.link('<cylinder radius="0.03" length="0.02"/>')
        w.joint("continuous", base, swivel, (-0.2, y / 2, -0.1), (0, 0, 1))
        w.joint("continuous", swivel, wheel, (-0.03, 0.0, -0.07), (0, 1, 0))
    tree = load_urdf(w.urdf())
    assert feet(tree) == frozenset()


def test_a_grippers_tool_point_on_the_flange_beside_its_coupling_is_mounted_with_it():
    """A two-jaw gripper bolted through a coupling to an arm's flange, with the arm's tool point a bare frame on the
    flange out among the jaws' tips: the shape mounts the jaws and the point at the flange, where they meet, so
    they are one tool (the point on its own became a second, rigid tool)."""
    w = Writer(random.Random(6))
    link = w.arm(w.link('<box size="0.3 0.3 0.1"/>'))
    flange, coupling, palm = w.link(), w.link('<cylinder radius="0.04" length="0.02"/>'), w.link('<box size="0.08 0.04 0.06"/>')
    w.joint("fixed", link, flange, (0.0, 0.0, 0.1))
    w.joint("fixed", flange, coupling, (0.0, 0.0, 0.01))
    w.joint("fixed", coupling, palm, (0.0, 0.0, 0.04))
    jaws = []
    for y, axis in ((0.03, (0.0, -1.0, 0.0)), (-0.03, (0.0, 1.0, 0.0))):
        jaw = w.link('<box size="0.01 0.01 0.06"/>')
        w.joint("prismatic", palm, jaw, (0.0, y, 0.06), axis, (0.0, 0.025))
        jaws.append(jaw)
    point = w.link()
    w.joint("fixed", flange, point, (0.0, 0.0, 0.16))
    tree = load_urdf(w.urdf())
    mounts = hand_mounts(tree, hands(tree))
    assert mounts == {jaws[0]: flange, jaws[1]: flange, point: flange}


@pytest.mark.parametrize("prismatic", [False, True])
@pytest.mark.parametrize("seed", range(4))
def test_two_jaws_moving_as_mirror_images_with_no_inertial_are_no_sensors(seed, prismatic):
    """A short arm (a lift and an elbow) ending in two jaws drawn with one mesh, each on its own bounded joint, hung
    and moving as mirror images, the file stating no <inertial> (so nothing says which way they close): the erring
    model calls them sensors at 0.6 (a service robot's jaws became force-torque sensors); they get its next answer.
    Two frames fixed mirrored on a body, and two drawn leaves moving the same way, are left to the model."""
    rng = random.Random(seed)
    w = Writer(rng)
    base, lift, forearm = w.link('<box size="0.4 0.4 0.3"/>'), w.link('<box size="0.05 0.05 0.1"/>'), \
        w.link('<box size="0.3 0.04 0.04"/>')
    w.joint("prismatic", base, lift, (0.1, 0.0, 0.4), (0.0, 0.0, 1.0), (0.0, 0.7))
    w.joint("revolute", lift, forearm, (0.0, 0.0, -0.08), (0.0, 1.0, 0.0), (0.0, 1.57))
    mesh = '<mesh filename="package://bot/meshes/finger.dae"/>'
    jaws = [f"jaw_{k}" for k in range(2)]
    w.links += [f'<link name="{j}"><visual><geometry>{mesh}</geometry></visual></link>' for j in jaws]
    gap = rng.uniform(0.012, 0.03)
    for jaw, side in zip(jaws, (1.0, -1.0)):
        axis = (0.0, side, 0.0) if prismatic else (0.0, 0.0, side)
        w.joint("prismatic" if prismatic else "revolute", forearm, jaw, (0.32, side * gap, 0.0), axis,
                (0.0, 0.02) if prismatic else (0.0, 1.0))
    holder, frames = w.link('<box size="0.1 0.1 0.1"/>'), [w.link(), w.link()]
    w.joint("fixed", base, holder, (-0.1, 0.0, 0.3))
    for frame, side in zip(frames, (1.0, -1.0)):
        w.joint("fixed", holder, frame, (0.0, side * 0.04, 0.05))
    urdf = w.urdf()
    assert jaw_pairs(load_urdf(urdf)) == set(jaws)
    options = {TAX.answer(SENSOR_CLS): 0.6, TAX.answer(TOOL_CLS): 0.4}
    claims = _identified(urdf, lambda q: options if _leaf(q) in jaws + frames else NONE)
    assert [claims[j] for j in jaws] == [TOOL_CLS, TOOL_CLS] and [claims[f] for f in frames] == [SENSOR_CLS] * 2
    same_way = urdf.replace(b'<axis xyz="0 0 -1"/>', b'<axis xyz="0 0 1"/>').replace(b'<axis xyz="0 -1 0"/>',
                                                                                        b'<axis xyz="0 1 0"/>')
    assert not jaw_pairs(load_urdf(same_way))


def _scissors(seed: int, across: bool) -> tuple[bytes, list[str]]:
    """A six-joint arm ending in a gripper body carrying two jaws hinged at one point about one line, each drawn with
    its own mesh (a left and a right one), of one mass; the second written as the first turned half a turn about
    the arm's axis (its joint's axis opposed, its centre of mass across the pin) where `across`, else as the first."""
    rng = random.Random(seed)
    w = Writer(rng)
    link = w.arm(w.link('<box size="0.3 0.3 0.1"/>'))
    body = w.link('<box size="0.04 0.05 0.03"/>', centre=(0.0, 0.0, 0.0), mass=0.2)
    w.joint("fixed", link, body, (0.0, 0.0, 0.05))
    out, mass = rng.uniform(0.015, 0.03), rng.uniform(0.02, 0.05)
    jaws = []
    for side, yaw in (("r", 0.0), ("l", math.pi if across else 0.0)):
        jaw = w.link(f'<mesh filename="package://bot/meshes/finger_{side}.stl"/>', centre=(0.002, out, 0.03),
                     mass=mass)
        w.joint("revolute", body, jaw, (0.0, 0.0, 0.034), (1.0, 0.0, 0.0), (-0.44, 0.3), rpy=(0.0, 0.0, yaw))
        jaws.append(jaw)
    return w.urdf(), jaws


@pytest.mark.parametrize("seed", range(4))
def test_two_jaws_hinged_on_one_pin_are_no_sensors(seed):
    """Scissor jaws (_scissors: a Katana's, whose fingers the model called touch sensors): the erring model calls them
    sensors at 0.6; they get its next answer. Two leaves on one pin with their masses on one side of it are left to
    the model."""
    urdf, jaws = _scissors(seed, across=True)
    assert jaw_pairs(load_urdf(urdf)) == set(jaws)
    options = {TAX.answer(SENSOR_CLS): 0.6, TAX.answer(TOOL_CLS): 0.4}
    claims = _identified(urdf, lambda q: options if _leaf(q) in jaws else NONE)
    assert [claims[j] for j in jaws] == [TOOL_CLS, TOOL_CLS]
    one_side, _ = _scissors(seed, across=False)
    assert not jaw_pairs(load_urdf(one_side))


@pytest.mark.parametrize("seed", range(4))
def test_a_servo_horn_spinning_beside_a_grippers_fingers_is_the_grippers_mechanism(seed):
    """An arm ends in a bare frame carrying a servo horn on a joint that turns without bound, a drawn camera fixed
    beside it and a finger bar whose two fingers slide against each other (one mimicking the other) towards a tool
    point. The horn is no body fixed beside the gripper (it may be the tool's), and of the gripper's chains the
    fingers are its fingers and the horn its mechanism: a finger closes over a bounded arc (on the code before: the
    horn was a third, pivoting finger, or left out of the gripper)."""
    from urdfkb.pipeline.abstraction.structure import tool_structure
    rng = random.Random(seed)
    w = Writer(rng)
    base = w.link('<box size="0.3 0.3 0.1"/>', centre=(0.0, 0.0, 0.0), mass=5.0)
    end = w.link()
    w.joint("fixed", w.arm(base), end, (0.04, 0.0, 0.0))
    horn = w.link('<cylinder radius="0.012" length="0.004"/>', centre=(0.0, 0.004, 0.0), mass=0.005)
    w.joint("continuous", end, horn, (0.005, 0.0, 0.0), axis=(1.0, 0.0, 0.0))
    camera = w.link('<box size="0.02 0.05 0.02"/>', centre=(0.0, 0.0, 0.0), mass=0.05)
    w.joint("fixed", end, camera, (-0.02, 0.0, 0.04))
    bar = w.link('<box size="0.02 0.08 0.02"/>', centre=(0.0, 0.0, 0.0), mass=0.03)
    w.joint("fixed", end, bar, (0.01, 0.0, 0.0))
    fingers, drive = [], None
    for side in (1.0, -1.0):
        finger = w.link('<box size="0.03 0.01 0.015"/>', centre=(0.015, 0.0, 0.0), mass=0.01)
        drive = w.joint("prismatic", bar, finger, (0.02, 0.0, 0.0), axis=(0.0, side, 0.0),
                        limits=(0.015, 0.037), mimic=drive, multiplier=1.0)
        fingers.append(finger)
    tip = w.link()
    w.joint("fixed", bar, tip, (0.05, 0.0, 0.0))
    tree = load_urdf(w.urdf())
    off = off_limb_ends(tree, hands(tree))
    assert camera in off and horn not in off
    structure = tool_structure(tree, [horn, *fingers, tip])
    assert sorted(f.name for f in structure.fingers) == sorted(fingers) and structure.mechanisms == (horn,)
    assert {f.motion for f in structure.fingers} == {"prismatic"} and structure.grasps()
