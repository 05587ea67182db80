"""The body pass on generated robots with known truth (tests/body_robots.py): candidate chains over
hundreds of seeds (structure only), and whole passes with the scripted reasoner and a scripted model."""
from __future__ import annotations

import random
from dataclasses import replace

import pytest

from tests.body_robots import Built, legged, wheeled
from tests.scripted_reasoner import scripted_reasoner
from tests.urdf_writer import Writer
from urdfkb.pipeline.abstraction.abstractor import BODY_PASS, Abstractor
from urdfkb.pipeline.abstraction.components import SENSOR, BodyPart, Component, SubComponent
from urdfkb.pipeline.reading.ingest import load_urdf
from urdfkb.pipeline.llm.scripted import ScriptedBackend
from urdfkb.pipeline.knowledge.ontology import vocabulary
from urdfkb.pipeline.abstraction.oracle import Oracle
from urdfkb.pipeline.abstraction.passes import PassManager
from urdfkb.pipeline.abstraction import hands
from urdfkb.pipeline.abstraction.stages import body
from urdfkb.pipeline.abstraction.steps.findings import Findings


def _candidates(built: Built) -> set[tuple[str, ...]]:
    tree = load_urdf(built.urdf)
    owned = {j for joints in built.device_joints.values() for j in joints}
    links = {link for c in built.components for link in c.links}
    return {tuple(e.joint for e in c.joints) for c in body.chains(tree, owned, links)}


@pytest.mark.slow
@pytest.mark.parametrize("make", [wheeled, legged])
def test_candidate_chains_are_the_parts_over_many_seeds(make):
    """Every part built is one candidate (a mobile base's swivels each a candidate of their own)."""
    for seed in range(300):
        built = make(seed)
        expected = {tuple(p.joints) for p in built.parts if p.cls != "MobileBase"}
        expected |= {(j,) for p in built.parts if p.cls == "MobileBase" for j in p.joints}
        assert _candidates(built) == expected, seed


@pytest.mark.parametrize("dummy", ["", '<visual><geometry><box size="0.01 0.01 0.01"/></geometry></visual>'])
@pytest.mark.parametrize("seed", range(0, 60, 7))
def test_virtual_joints_that_place_the_whole_robot_are_no_part(seed, dummy):
    """A file that moves its mobile base without its wheels writes virtual x, y and yaw joints between bare frames,
    or dummy links drawn as 1 cm boxes, above the base (a planar base as joints; the model called them an arm): they
    place the whole robot, so the candidates are the robot's own parts, as without them."""
    built = wheeled(seed)
    root = load_urdf(built.urdf).root
    virtual = (f'<link name="v_world"/><link name="v_x">{dummy}</link><link name="v_y">{dummy}</link>'
               '<joint name="v_jx" type="prismatic"><parent link="v_world"/><child link="v_x"/><axis xyz="1 0 0"/>'
               '<limit lower="-5" upper="5" effort="1" velocity="1"/></joint>'
               '<joint name="v_jy" type="prismatic"><parent link="v_x"/><child link="v_y"/><axis xyz="0 1 0"/>'
               '<limit lower="-5" upper="5" effort="1" velocity="1"/></joint>'
               f'<joint name="v_jz" type="continuous"><parent link="v_y"/><child link="{root}"/><axis xyz="0 0 1"/></joint>')
    placed = replace(built, urdf=built.urdf.replace(b"</robot>", virtual.encode() + b"</robot>"))
    assert load_urdf(placed.urdf).root == "v_world"
    assert _candidates(placed) == _candidates(built)


def test_an_arms_first_joint_on_a_bare_root_frame_is_the_arms():
    """An arm whose first joint hangs straight on a bare root frame (no fixed base link between): that joint moves a
    body and follows no other, so it is the arm's, not a joint placing the robot."""
    w = Writer(random.Random(9))
    root = w.link()
    link, joints = root, []
    for k in range(5):
        child = w.link('<box size="0.05 0.05 0.2"/>')
        joints.append(w.joint("revolute", link, child, (0.0, 0.0, 0.2 if k else 0.0)))
        link = child
    tree = load_urdf(w.urdf())
    assert [[e.joint for e in c.joints] for c in body.chains(tree, set(), set())] == [joints]


def test_a_rail_or_a_pan_and_tilt_on_a_bare_root_is_no_virtual_base():
    """A rail under an arm on a bare carriage, and a pan and tilt whose pan link is a bare frame, both on a bare root
    frame: their joints move the robot's parts (no floating or planar joint, no two sliding joints square to each
    other), so they stay candidates."""
    w = Writer(random.Random(10))
    world, carriage = w.link(), w.link()
    rail = w.joint("prismatic", world, carriage, axis=(1.0, 0.0, 0.0), limits=(0.0, 2.0))
    link, arm = carriage, []
    for k in range(6):
        child = w.link('<box size="0.05 0.05 0.2"/>')
        arm.append(w.joint("revolute", link, child, (0.0, 0.0, 0.2 if k else 0.0)))
        link = child
    assert {tuple(e.joint for e in c.joints) for c in body.chains(load_urdf(w.urdf()), set(), set())} \
        == {(rail,), tuple(arm)}
    w = Writer(random.Random(11))
    root, pan, camera = w.link(), w.link(), w.link('<box size="0.05 0.1 0.05"/>')
    joints = [w.joint("revolute", root, pan), w.joint("revolute", pan, camera, (0.0, 0.0, 0.05), (0.0, 1.0, 0.0))]
    assert [[e.joint for e in c.joints] for c in body.chains(load_urdf(w.urdf()), set(), set())] == [joints]


def test_a_wheel_written_revolute_without_range_is_split_off_the_leg_it_ends():
    """Files write wheels as revolute joints with a <limit> that gives no range ("actually continuous"): such a
    joint spins, so a wheel at the end of a leg is a wheel candidate of its own, as a continuous one is."""
    w = Writer(random.Random(5))
    trunk = parent = w.link('<box size="0.5 0.3 0.1"/>')
    leg = []
    for i in range(3):
        child = w.link('<box size="0.03 0.03 0.2"/>')
        leg.append(w.joint("revolute", parent, child, (0.2, 0.1, 0) if not i else (0, 0, -0.2), (0, 1, 0)))
        parent = child
    wheel = w.link('<cylinder radius="0.08" length="0.04"/>')
    w.joints.append(f'<joint name="spin" type="revolute"><parent link="{parent}"/><child link="{wheel}"/>'
                    '<origin xyz="0 0 -0.2" rpy="1.5708 0 0"/><axis xyz="0 0 1"/><limit effort="35" velocity="20"/></joint>')
    tree = load_urdf(w.urdf())
    assert tree.edge_to(wheel).spins and not any(tree.edge_to(link).spins for link in tree.links if link not in (trunk, wheel))
    found = body.chains(tree, set(), set())
    assert {tuple(e.joint for e in c.joints) for c in found} == {tuple(leg), ("spin",)}
    told = {tuple(e.joint for e in c.joints): f.joint_types for c, f in zip(found, body.findings(tree, found, []).facts)}
    assert told[("spin",)] == ("continuous",) and set(told[tuple(leg)]) == {"revolute"}  # the reasoner's Wheel axiom applies


def test_a_bar_written_continuous_following_a_bounded_joint_turns_as_that_joint_does_not_as_a_wheel():
    """A parallel arm's linkage bar is written as a chain of its own, a continuous joint with no range following
    the shoulder by <mimic>: it turns through the shoulder's arc, so the reasoner is told revolute and its Wheel
    axiom does not apply; a wheel following another wheel by <mimic> (a skid-steer side) still spins."""
    w = Writer(random.Random(9))
    base = w.link('<box size="0.4 0.3 0.1"/>')
    upper, fore = w.link('<box size="0.03 0.03 0.2"/>'), w.link('<box size="0.03 0.03 0.2"/>')
    shoulder = w.joint("revolute", base, upper, (0.0, 0.0, 0.1), (0, 1, 0), limits=(-0.3, 1.4))
    w.joint("revolute", upper, fore, (0.0, 0.0, 0.2), (0, 1, 0), limits=(-1.0, 1.0))
    bar = w.link('<box size="0.02 0.02 0.15"/>')
    w.joints.append(f'<joint name="bar_joint" type="continuous"><parent link="{base}"/><child link="{bar}"/>'
                    '<origin xyz="-0.03 0 0.12"/><axis xyz="0 1 0"/>'
                    f'<mimic joint="{shoulder}" multiplier="1"/></joint>')
    wheels = [w.link('<cylinder radius="0.05" length="0.03"/>') for _ in range(2)]
    w.joints.append(f'<joint name="front_spin" type="continuous"><parent link="{base}"/><child link="{wheels[0]}"/>'
                    '<origin xyz="0.15 0.17 -0.05" rpy="1.5708 0 0"/><axis xyz="0 0 1"/></joint>')
    w.joints.append(f'<joint name="rear_spin" type="continuous"><parent link="{base}"/><child link="{wheels[1]}"/>'
                    '<origin xyz="-0.15 0.17 -0.05" rpy="1.5708 0 0"/><axis xyz="0 0 1"/>'
                    '<mimic joint="front_spin" multiplier="1"/></joint>')
    tree = load_urdf(w.urdf())
    found = body.chains(tree, set(), set())
    told = {tuple(e.joint for e in c.joints): f.joint_types for c, f in zip(found, body.findings(tree, found, []).facts)}
    assert told[("bar_joint",)] == ("revolute",)
    assert told[("rear_spin",)] == ("continuous",) and told[("front_spin",)] == ("continuous",)


@pytest.mark.parametrize("seed", range(5))
def test_a_sensor_mount_whose_limits_leave_it_no_range_is_no_body_joint(seed):
    """Simulator files mount sensors on revolute joints limited to 0..0 (so the simulator keeps their links apart):
    such a joint carrying a device's links alone moves nothing of the body, so it makes no head or arm; a pan joint
    carrying a camera, a 0..0 joint carrying a link of the body (SolidWorks' exporter writes every joint so) and a
    wheel written continuous with a 0..0 limit all the same are candidates."""
    w = Writer(random.Random(seed))
    hull = w.link('<box size="1.0 0.4 0.3"/>')
    sensors = [w.link('<box size="0.05 0.05 0.05"/>') for _ in range(4)]
    mounts = [w.joint("revolute", hull, sensor, (0.4 - 0.2 * i, 0.0, -0.15), limits=(0.0, 0.0))
              for i, sensor in enumerate(sensors[:3])]
    pan = w.joint("revolute", hull, sensors[3], (0.3, 0.0, 0.2))
    fin = w.joint("revolute", hull, w.link('<box size="0.1 0.01 0.05"/>'), (-0.5, 0.0, 0.0), limits=(0.0, 0.0))
    wheel = w.joint("continuous", hull, w.link('<cylinder radius="0.1" length="0.04"/>'), (0.0, 0.25, -0.2),
                    (0, 1, 0), (0.0, 0.0))
    tree = load_urdf(w.urdf())
    assert all(e.movable and not e.moves for e in tree.edges if e.joint in mounts)
    found = {tuple(e.joint for e in c.joints) for c in body.chains(tree, set(), set(sensors))}
    assert found == {(pan,), (fin,), (wheel,)}


@pytest.mark.parametrize("seed", range(3))
def test_an_arm_whose_joints_are_all_written_0_0_is_no_sensor_mount(seed):
    """A hand-written file gives its arms' joints a <limit> of all zeros (as simulator files write sensor mounts)
    while its lift has a range, and each arm ends in a gripper: a joint carrying a limb's links that have joints of
    their own, or hanging from such a joint, is no device's mount, so each arm is a candidate of its six joints (on
    the code before: every joint of both arms a mount, the arms lost in the lift's chain); the camera's 0..0 mount
    on the chest still is one."""
    w = Writer(random.Random(seed))
    base = w.link('<box size="0.6 0.5 0.3"/>')
    chest = w.link('<box size="0.3 0.4 0.5"/>')
    lift = w.joint("prismatic", base, chest, (0.0, 0.0, 0.4), limits=(0.0, 0.3))
    arms, jaws, jaw_joints = [], set(), set()
    for y in (0.2, -0.2):
        link, joints = chest, []
        for i in range(6):
            child = w.link('<box size="0.05 0.05 0.2"/>')
            joints.append(w.joint("revolute", link, child, (0.0, y if i == 0 else 0.0, 0.2), (0.0, 0.0, 1.0) if i % 2
                                  else (0.0, 1.0, 0.0), unwritten=True))
            link = child
        arms.append(tuple(joints))
        for side in (0.03, -0.03):
            jaws.add(jaw := w.link('<box size="0.01 0.02 0.06"/>'))
            jaw_joints.add(w.joint("revolute", link, jaw, (0.0, side, 0.1), (1.0, 0.0, 0.0), unwritten=True))
    camera = w.link('<box size="0.03 0.1 0.03"/>')
    mount = w.joint("revolute", chest, camera, (0.1, 0.0, 0.3), limits=(0.0, 0.0))
    tree = load_urdf(w.urdf())
    assert not any(e.moves for e in tree.edges if e.joint in {mount, *(j for arm in arms for j in arm)})
    found = {tuple(e.joint for e in c.joints) for c in body.chains(tree, jaw_joints, {camera, *jaws})}
    assert set(arms) <= found and (lift,) in found and not any(mount in chain for chain in found)


def test_device_joints_are_the_fingers():
    built = wheeled(3)
    tree = load_urdf(built.urdf)
    joints = {c.name: list(body.device_joints(tree, c)) for c in built.components}
    assert joints == {c.name: built.device_joints.get(c.name, []) for c in built.components}
    assert any(joints.values())  # a gripper's fingers among them


def _torso_rule(built: Built, flip_sides: bool = False):
    """A model that calls a lift a torso, and reads sides as geometry does (or, flipped, the other way)."""
    torso = {p.joints[0] for p in built.parts if p.cls == "Torso"}

    def rule(question):
        if question.key.startswith("side:"):
            return question.options[1 if flip_sides else 0]
        if question.key.startswith("body:"):
            return "torso" if question.key[len("body:"):] in torso else "none"
        raise AssertionError(f"unexpected question {question.key}")
    return rule


def body_pass(oracle: Oracle, tree, components) -> tuple[list, list]:
    """The declared body pass (pipeline.abstraction.abstractor.BODY_PASS), step by step, on `components` as given."""
    found = Findings(components=list(components))
    context = Abstractor(oracle, vocabulary(), reasoner=scripted_reasoner).context(tree)
    PassManager(lambda _record: None).run(BODY_PASS, context, found)
    return found.body, found.components


def _two_arms_on_the_lift(seed: int) -> bool:
    return sum(p.cls == "Arm" for p in wheeled(seed).parts) == 2


def _run(built: Built, flip_sides: bool = False):
    tree = load_urdf(built.urdf)
    oracle = Oracle(ScriptedBackend(_torso_rule(built, flip_sides)))
    return body_pass(oracle, tree, list(built.components))


@pytest.mark.parametrize("make,seed", [(wheeled, s) for s in range(3)] + [(legged, s) for s in range(3)])
def test_the_pass_finds_every_part_with_its_class_side_and_devices(make, seed):
    built = make(seed)
    parts, components = _run(built)
    found = {(p.cls, p.joints, p.side) for p in parts if p.joints or p.cls == "MobileBase"}
    assert found == {(p.cls, tuple(p.joints), p.side) for p in built.parts if p.joints or p.cls == "MobileBase"}
    by_name = {p.name: p for p in parts}
    bases = [p.name for p in parts if p.cls == "MobileBase"]
    # wheels are the base's sub-components
    assert [p.parent for p in parts if p.cls == "Wheel"] == bases[:1] * sum(p.cls == "Wheel" for p in built.parts)
    located = {c.name: (list(c.joints), by_name[c.located_on].joints[0], c.side == by_name[c.located_on].side)
               for c in components}
    assert located == {c.name: (built.device_joints.get(c.name, []), built.located[c.name], True) for c in built.components}


@pytest.mark.parametrize("seed", [s for s in range(40) if _two_arms_on_the_lift(s)][:3])
def test_a_lift_carrying_two_arms_with_their_tools_is_a_torso_without_asking(seed):
    """A lift carrying two arms, each with its gripper, and a head the file gives no camera: the head is the model's
    to say, the lift is a torso by the ontology (it lifts both arms), never asked (a dual-arm robot's lift was typed
    an arm, its head bare)."""
    built = wheeled(seed, head_camera=False)
    lift = next(p.joints[0] for p in built.parts if p.cls == "Torso")
    head = next(p.joints[0] for p in built.parts if p.cls == "Head")
    asked = []

    def rule(question):
        asked.append(question.key)
        if question.key.startswith("side:"):
            return question.options[0]
        return "head" if question.key == f"body:{head}" else "arm"
    parts, _ = body_pass(Oracle(ScriptedBackend(rule)), load_urdf(built.urdf), list(built.components))
    assert f"body:{head}" in asked and f"body:{lift}" not in asked
    found = {(p.cls, p.joints, p.side) for p in parts if p.joints or p.cls == "MobileBase"}
    assert found == {(p.cls, tuple(p.joints), p.side) for p in built.parts if p.joints or p.cls == "MobileBase"}


def test_names_win_over_geometry_for_a_whole_class_of_mirrored_parts():
    built = legged(1)  # legs on both sides
    parts, _ = _run(built, flip_sides=True)
    truth = {tuple(p.joints): p.side for p in built.parts if p.side}
    flipped = {"left": "right", "right": "left"}
    assert {p.joints: p.side for p in parts if p.side} == {j: flipped[s] for j, s in truth.items()}


def test_a_robot_without_body_joints_has_no_parts():
    tree = load_urdf(b'<robot name="r"><link name="a"/><link name="b"/>'
                     b'<joint name="j" type="fixed"><parent link="a"/><child link="b"/></joint></robot>')
    oracle = Oracle(ScriptedBackend(lambda q: pytest.fail("no question expected")))
    assert body_pass(oracle, tree, []) == ([], [])


@pytest.mark.parametrize("seed", range(10))
def test_an_arm_whose_gripper_points_below_its_base_is_an_arm(seed):
    """A fixed arm written at a zero pose that points its gripper down past the plane it stands on (xArm6's): the
    gripper's links are the lowest of the robot, but they are the tool's, not the arm's, so the arm does not reach
    the ground and the reasoner's Arm axiom applies; the model (asked nothing) cannot make it a head."""
    rng = random.Random(seed)
    w = Writer(rng)
    world, base = w.link(), w.link('<cylinder radius="0.06" length="0.1"/>')
    w.joint("fixed", world, base)
    link, joints = base, []
    for z in (0.25, 0.3, -0.3, -0.3):  # up, up, then folded back down past the base's plane
        child = w.link('<box size="0.05 0.05 0.1"/>')
        joints.append(w.joint("revolute", link, child, (0.08 if z < 0 else 0.0, 0.0, z), (0.0, 1.0, 0.0)))
        link = child
    palm, fingers = w.link(), []
    w.joint("fixed", link, palm, (0.0, 0.0, -0.05))
    for side in (1.0, -1.0):
        jaw = w.link()
        w.joint("prismatic", palm, jaw, (0.0, side * 0.03, -0.05), (0.0, -side, 0.0), (0.0, 0.03))
        fingers.append(jaw)
    tree = load_urdf(w.urdf())
    gripper = Component("gripper", "end_effector", "ParallelGripper", 1.0, link,
                        tuple(SubComponent(x, "Finger", 1.0) for x in (palm, *fingers)))

    def rule(question):
        raise AssertionError(f"unexpected question {question.key}")
    parts, _ = body_pass(Oracle(ScriptedBackend(rule)), tree, [gripper])
    assert [(p.cls, list(p.joints)) for p in parts] == [("Arm", joints)]


def test_an_upper_bodys_bare_arms_hanging_lowest_are_no_legs():
    """A dual-arm upper body (a waist joint, a head, two bare six-joint arms hanging straight down at the zero pose)
    whose stand the file leaves out: the arms' ends are its lowest links, so each arm "reached the ground" and the
    reasoner made both legs. Nothing stands on them (no feet: hands.feet), so the reasoner's Arm axiom applies, as it
    does to the legs of a robot standing on them (test_the_pass_finds_every_part_with_its_class_side_and_devices)."""
    w = Writer(random.Random(21))
    waist = w.link('<box size="0.3 0.3 0.2"/>')
    chest = w.link('<box size="0.3 0.4 0.3"/>')
    torso = [w.joint("revolute", waist, chest, (0.0, 0.0, 0.2), limits=(-1.5, 1.5))]
    neck = w.link('<box size="0.05 0.05 0.05"/>')
    head = [w.joint("revolute", chest, neck, (0.0, 0.0, 0.3), limits=(-1.5, 1.5))]
    skull = w.link('<box size="0.15 0.15 0.15"/>')
    head.append(w.joint("revolute", neck, skull, (0.0, 0.0, 0.05), (0.0, 1.0, 0.0), (-0.5, 0.5)))
    lens = w.link()
    w.joint("fixed", skull, lens, (0.08, 0.0, 0.0))
    camera = Component("camera", "sensor", "Camera", 1.0, skull, (SubComponent(lens, "RgbFrame", 1.0),))
    arms = []
    for y in (0.25, -0.25):
        link, joints = chest, []
        for k in range(6):
            child = w.link('<box size="0.06 0.06 0.15"/>')
            joints.append(w.joint("revolute", link, child, (0.0, y, 0.2) if k == 0 else (0.0, 0.0, -0.15),
                                  (0.0, 0.0, 1.0) if k in (0, 3) else (0.0, 1.0, 0.0), (-2.0, 2.0)))
            link = child
        arms.append(joints)
    tree = load_urdf(w.urdf())
    assert min(tree.position_in(link, tree.root)[2] for link in tree.links) < -0.3  # the arms' ends hang lowest

    def rule(question):
        if question.key.startswith("side:"):
            return question.options[0]
        assert question.key == f"body:{torso[0]}", question.key  # the joint turning arms and head: asked
        return "torso"
    parts, _ = body_pass(Oracle(ScriptedBackend(rule)), tree, [camera])
    assert sorted((p.cls, list(p.joints)) for p in parts) == sorted(
        [("Arm", arms[0]), ("Arm", arms[1]), ("Head", head), ("Torso", torso)])


def _arms_across(axis: int, left_sign: float):
    """Two mirrored 3-joint arms on a trunk, reaching out across the root's `axis` (a CAD export with y up places
    them across x), the left one on the `left_sign` side; their joints' names say which is left."""
    w = Writer(random.Random(axis))
    trunk = w.link('<box size="0.3 0.3 0.3"/>')
    parts = {}
    for side, sign in (("left", left_sign), ("right", -left_sign)):
        parent, joints, links = trunk, [], []
        for i in range(3):
            child = w.link('<cylinder radius="0.03" length="0.2"/>')
            offset = [0.0, 0.0, 0.0]
            offset[axis] = 0.2 * sign
            name = f"{side}_arm_{i}"
            w.joints.append(f'<joint name="{name}" type="revolute"><parent link="{parent}"/><child link="{child}"/>'
                            f'<origin xyz="{" ".join(map(str, offset))}"/>'
                            '<axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>')
            joints.append(name)
            links.append(child)
            parent = child
        parts[side] = BodyPart(f"arm_{side}", "Arm", 1.0, trunk, tuple(joints), tuple(links))
    return load_urdf(w.urdf()), parts


def _names_say(left_first: bool, share: float = 1.0):
    def rule(question):
        assert question.key.startswith("side:")
        left = next(o for o in question.options if o.startswith("left"))
        return {o: (share if (o == left) == left_first else 1.0 - share) for o in question.options}
    return rule


@pytest.mark.parametrize("axis", [0, 2])
@pytest.mark.parametrize("left_sign", [1.0, -1.0])
def test_parts_paired_across_another_axis_take_their_sides_from_the_names(axis, left_sign):
    """A robot drawn with another axis across it (no part pairs across y): the names alone say which is left."""
    tree, parts = _arms_across(axis, left_sign)
    oracle = Oracle(ScriptedBackend(_names_say(True)))
    sided = body.sides(oracle, tree, list(parts.values()), None, lambda _msg: None)
    assert {p.name: p.side for p in sided} == {"arm_left": "left", "arm_right": "right"}


def test_parts_paired_across_another_axis_get_no_side_when_the_model_is_unsure():
    tree, parts = _arms_across(0, 1.0)
    oracle = Oracle(ScriptedBackend(_names_say(True, share=0.6)))
    sided = body.sides(oracle, tree, list(parts.values()), None, lambda _msg: None)
    assert {p.side for p in sided} == {None}


def test_a_bare_arm_of_six_joints_is_an_arm_without_asking():
    """An industrial arm with nothing on its flange (no end-effector found): five joints or more off the ground
    carrying no further part are an arm by the ontology's definition (the scripted reasoner stands for HermiT,
    test_reasoner_agreement), so the model is not asked."""
    w = Writer(random.Random(11))
    world, base = w.link(), w.link('<cylinder radius="0.1" length="0.2"/>')
    w.joint("fixed", world, base)
    link, joints = base, []
    for i, z in enumerate((0.2, 0.1, 0.4, 0.1, 0.3, 0.1)):
        child = w.link('<box size="0.06 0.06 0.2"/>')
        joints.append(w.joint("revolute", link, child, (0.0, 0.0, z), (0.0, 0.0, 1.0) if i % 3 == 0 else (0.0, 1.0, 0.0)))
        link = child
    flange = w.link()
    w.joint("fixed", link, flange, (0.0, 0.0, 0.05))
    oracle = Oracle(ScriptedBackend(lambda q: pytest.fail(f"unexpected question {q.key}")))
    parts, _ = body_pass(oracle, load_urdf(w.urdf()), [])
    assert [(p.cls, p.joints) for p in parts] == [("Arm", tuple(joints))]


def test_a_continuous_joint_its_file_bounds_to_less_than_half_a_turn_does_not_spin():
    """A linkage's bar written continuous with a range all the same (as Drake's Robotiq 3-finger gripper writes its
    bars): held by the loop it closes, it does not spin, so no wheel, and the reasoner is told it is revolute. A
    continuous joint with no range, or one of half a turn or more (-3.14 to 3.14, as wheels are written), spins;
    one following another by <mimic> (a rear wheel of a skid-steer base) is told continuous, as written."""
    w = Writer(random.Random(3))
    base = w.link('<box size="0.5 0.3 0.1"/>')
    bounded, free, wide, rear = (w.link('<cylinder radius="0.01" length="0.04"/>') for _ in range(4))
    w.joint("continuous", base, bounded, (0.2, 0.0, 0.0), (0, 1, 0), (1.09, 1.94))
    front = w.joint("continuous", base, free, (-0.2, 0.0, 0.0), (0, 1, 0))
    w.joint("continuous", base, wide, (0.0, 0.2, 0.0), (0, 1, 0), (-3.14, 3.14))
    w.joint("continuous", base, rear, (-0.4, 0.0, 0.0), (0, 1, 0), mimic=front)
    tree = load_urdf(w.urdf())
    links = (bounded, free, wide, rear)
    assert [tree.edge_to(link).spins for link in links] == [False, True, True, False]
    assert [body._motion(tree, tree.edge_to(link)) for link in links] == ["revolute", "continuous", "continuous", "continuous"]


def _sprawled(seed: int, pairs: int, kind: str = "revolute", rise: float = 0.0,
              limits: tuple[float, float] | None = None, feet: bool = True) -> tuple[bytes, list[list[str]]]:
    """A trunk with `pairs` mirrored pairs of legs spread front to back, each of 3 joints of `kind` (within `limits`,
    where given), that the zero pose holds out level with the trunk and folded (its foot back beside its hip; with
    no `feet`, the shank is the leg's last link), `rise` above it (actuators stacked at the hip), its name
    meaningless."""
    rng = random.Random(seed)
    w = Writer(rng)
    trunk = w.link('<box size="0.8 0.2 0.1"/>')
    legs = []
    for k in range(pairs):
        x = 0.3 - 0.6 * k / (pairs - 1)
        for y in (0.1, -0.1):
            hip, thigh, shank = w.link('<box size="0.1 0.05 0.05"/>'), w.link('<box size="0.3 0.04 0.04"/>'), \
                w.link('<box size="0.3 0.03 0.03"/>')
            legs.append([w.joint(kind, trunk, hip, (x, y, 0.0), (1.0, 0.0, 0.0), limits),
                         w.joint(kind, hip, thigh, (0.0, 0.08 if y > 0 else -0.08, rise), (0.0, 1.0, 0.0), limits),
                         w.joint(kind, thigh, shank, (0.3, 0.0, 0.0), (0.0, 1.0, 0.0), limits)])
            if feet:
                w.joint("fixed", shank, w.link('<sphere radius="0.03"/>'), (-0.3, 0.0, 0.0))
    return w.urdf(), legs


def _each_a_leg_whatever_the_model_says(tree, legs: list[list[str]], answer: str) -> None:
    """The body pass, the model answering `answer` for every part, makes each of `legs` (its joints) a leg."""
    def rule(question):
        return question.options[0] if question.key.startswith("side:") else answer
    parts, _ = body_pass(Oracle(ScriptedBackend(rule)), tree, [])
    assert sorted((p.cls, list(p.joints)) for p in parts) == sorted(("Leg", joints) for joints in legs)


@pytest.mark.parametrize("seed,pairs", [(3, 2), (4, 3)])
def test_legs_the_zero_pose_holds_out_level_are_legs(seed, pairs):
    """A quadruped or hexapod whose file's zero pose folds its legs flat beside its trunk: nothing lies below the
    trunk, yet its legs leave it in mirrored pairs spread front to back, so their tips are feet (hands.feet) and the
    legs reach the ground: the reasoner makes each a leg, whatever the model would have said (here "torso")."""
    urdf, legs = _sprawled(seed, pairs)
    tree = load_urdf(urdf)
    assert max(abs(tree.position_in(link, tree.root)[2]) for link in tree.links) < 0.01  # all level with the trunk
    _each_a_leg_whatever_the_model_says(tree, legs, "torso")


@pytest.mark.parametrize("seed,pairs", [(5, 2), (6, 3)])
def test_legs_written_continuous_with_their_hips_raised_are_legs_not_wheels(seed, pairs):
    """Sprawled legs whose joints the file writes continuous (servo legs' files leave the limits out) and whose
    hips lift them 0.1 m above the trunk: each leg's last segment spins on its knee but carries its foot out from
    it (hands.wheel_body), so the limbs are legs and no knee is split off as a wheel (on the code before: six wheels
    and no feet)."""
    urdf, legs = _sprawled(seed, pairs, kind="continuous", rise=0.1)
    tree = load_urdf(urdf)
    assert len(hands.feet(tree)) == 2 * pairs
    _each_a_leg_whatever_the_model_says(tree, legs, "wheel")


@pytest.mark.parametrize("seed,pairs", [(7, 2), (8, 3)])
def test_servo_legs_ending_in_their_shanks_are_legs_not_a_hand(seed, pairs):
    """Sprawled legs on hobby servos (each joint's range 300 degrees, more than half a turn) that end in their
    shanks, no foot link: a shank's range is no wheel's full turn, so the tips are feet and each limb a leg (on the
    code before the shanks rolled as wheels do: no feet, and a real hexapod so written became one hand)."""
    urdf, legs = _sprawled(seed, pairs, limits=(-2.618, 2.618), feet=False)
    tree = load_urdf(urdf)
    assert len(hands.feet(tree)) == 2 * pairs
    _each_a_leg_whatever_the_model_says(tree, legs, "arm")


@pytest.mark.parametrize("seed,pairs", [(9, 2), (10, 3)])
def test_servo_legs_written_with_a_full_turn_each_are_legs_not_a_hand(seed, pairs):
    """Sprawled legs whose file gives every servo a full turn (-3.14..3.14), ending in their shanks: a shank's full
    turn says nothing of a wheel where every joint of its limb is so written, so the tips are feet and each limb a
    leg (on the code before, a real hexapod so written became one hand of six fingers, its head among them)."""
    urdf, legs = _sprawled(seed, pairs, limits=(-3.14, 3.14), feet=False)
    tree = load_urdf(urdf)
    assert len(hands.feet(tree)) == 2 * pairs and not hands.hands(tree)
    _each_a_leg_whatever_the_model_says(tree, legs, "arm")


def _steered_wheels(seed: int, steering: tuple[float, float], drive: tuple[float, float], drop: float) -> bytes:
    """A trunk on four mirrored steered wheels, each a steering joint within `steering` and a drive joint, `drop`
    below it, within `drive`, both written revolute."""
    w = Writer(random.Random(seed))
    trunk = w.link('<box size="0.8 0.5 0.2"/>')
    for x in (0.3, -0.3):
        for y in (0.22, -0.22):
            fork, wheel = w.link('<box size="0.05 0.05 0.15"/>'), w.link('<box size="0.05 0.14 0.14"/>')
            w.joint("revolute", trunk, fork, (x, y, 0.0), (0.0, 0.0, 1.0), steering)
            w.joint("revolute", fork, wheel, (0.0, 0.0, -drop), (0.0, 1.0, 0.0), drive)
    return w.urdf()


def test_steered_wheels_written_with_a_full_turn_are_still_wheel_modules():
    """Four mirrored steered wheels whose steering and drive joints are both written revolute with a full turn: two
    joints a limb, too few to say a servo robot's file, so the drive joint's full turn rolls a wheel: no feet."""
    assert hands.feet(load_urdf(_steered_wheels(11, (-3.14, 3.14), (-3.14, 3.14), 0.0))) == frozenset()


def test_steered_wheels_whose_drive_joints_are_held_at_zero_are_no_legs():
    """Four mirrored steering joints with a range, each carrying a wheel on a revolute joint written 0..0 (an export
    that gave the steering its range and the drive none): a joint whose limits leave it no range moves nothing where
    the file ranges others (KinematicTree.moving), so each limb has one moving joint and no feet are found (on the code
    before: four sprawled legs, settled at 1.0)."""
    assert hands.feet(load_urdf(_steered_wheels(12, (-2.97, 2.97), (0.0, 0.0), 0.14))) == frozenset()


@pytest.mark.parametrize("seed", [14, 15])
def test_a_biped_whose_root_origin_lies_on_the_floor_stands_on_its_feet(seed):
    """An exported biped whose pelvis link has its origin on the floor and its hips 0.55 m above it, each leg of six
    joints ending in its ankle link (the foot's body, no foot frame below it): the legs leave the pelvis high above
    the ankles, so the ankles are feet and the limbs legs, whatever the model says (on the code before: the pelvis
    lay lower than the ankles, no feet; the legs became arms and the ankles grippers)."""
    rng = random.Random(seed)
    w = Writer(rng)
    pelvis = w.link('<box size="0.2 0.3 0.15"/>')
    legs, ankles = [], []
    for y in (0.08, -0.08):
        parent, joints = pelvis, []
        for i, (xyz, axis) in enumerate((((0.0, y, 0.55), (1, 0, 0)), ((0.0, 0.0, -0.04), (0, 0, 1)),
                                         ((0.0, 0.0, -0.04), (0, 1, 0)), ((0.0, 0.0, -0.2), (0, 1, 0)),
                                         ((0.0, 0.0, -0.18), (0, 1, 0)), ((0.0, 0.0, -0.02), (1, 0, 0)))):
            child = w.link('<box size="0.04 0.04 0.2"/>' if i < 5 else '<box size="0.2 0.08 0.03"/>')
            joints.append(w.joint("revolute", parent, child, xyz, axis, (-1.5, 1.5)))
            parent = child
        legs.append(joints)
        ankles.append(parent)
    tree = load_urdf(w.urdf())
    assert hands.feet(tree) == frozenset(ankles)
    _each_a_leg_whatever_the_model_says(tree, legs, "arm")


def test_a_spinning_wheel_on_a_steering_joint_is_still_a_wheel_module():
    """Four mirrored steered wheels spread front to back, level with the trunk: the drive joint spins a body whose
    frames all lie on its axis (hands.wheel_body), so the limbs are wheel modules, not sprawled legs."""
    w = Writer(random.Random(8))
    trunk, wheels = w.link('<box size="0.8 0.4 0.1"/>'), []
    for x in (0.3, -0.3):
        for y in (0.2, -0.2):
            fork, wheel, hub = w.link('<box size="0.05 0.05 0.1"/>'), w.link('<cylinder radius="0.08" length="0.04"/>'), w.link()
            w.joint("revolute", trunk, fork, (x, y, 0.0), (0.0, 0.0, 1.0))
            w.joint("continuous", fork, wheel, (0.0, 0.0, 0.0), (0.0, 1.0, 0.0))
            w.joint("fixed", wheel, hub, (0.0, 0.03, 0.0))
            wheels.append(wheel)
    tree = load_urdf(w.urdf())
    assert all(hands.wheel_body(tree, wheel) for wheel in wheels) and hands.feet(tree) == frozenset()


@pytest.mark.parametrize("tool_share, camera_share", [(0.14, 0.6), (0.9, 0.35)])
def test_a_part_the_ontology_settles_by_its_devices_is_as_sure_as_they_are(tool_share, camera_share):
    """A neck of two joints carrying a tool the model only half believed in is an arm by the ontology, and a head
    carrying a camera a head: each takes the confidence of the device its class rests on (on the code before: 1.0,
    so a humanoid's neck carrying its spinning laser, taken for a gripper at 0.14, was an arm no reviewer was shown);
    an arm of six joints with its gripper is an arm by its joints alone, 1.0."""
    w = Writer(random.Random(33))
    trunk = w.link('<box size="0.4 0.4 0.6"/>')
    neck, head = w.link('<box size="0.05 0.05 0.05"/>'), w.link('<box size="0.15 0.15 0.15"/>')
    tool_neck = [w.joint("revolute", trunk, neck, (0.1, 0.0, 0.35), limits=(-1.0, 1.0)),
                 w.joint("revolute", neck, head, (0.0, 0.0, 0.05), (0.0, 1.0, 0.0), (-0.5, 0.5))]
    spinner = w.link('<cylinder radius="0.03" length="0.06"/>')
    w.joint("fixed", head, spinner, (0.0, 0.0, 0.1))
    pan, skull = w.link('<box size="0.05 0.05 0.05"/>'), w.link('<box size="0.1 0.1 0.1"/>')
    camera_neck = [w.joint("revolute", trunk, pan, (-0.1, 0.0, 0.35), limits=(-1.0, 1.0))]
    camera_neck.append(w.joint("revolute", pan, skull, (0.0, 0.0, 0.05), (0.0, 1.0, 0.0), (-0.5, 0.5)))
    lens = w.link()
    w.joint("fixed", skull, lens, (0.06, 0.0, 0.0))
    hand = w.arm(trunk)
    jaw = w.link('<box size="0.01 0.02 0.05"/>')
    w.joint("fixed", hand, jaw, (0.0, 0.0, 0.05))
    tree = load_urdf(w.urdf())
    devices = [Component("spinner", "end_effector", "EndEffector", tool_share, head, (SubComponent(spinner, "ToolHousing", 1.0),)),
               Component("camera", "sensor", "MonocularCamera", camera_share, skull, (SubComponent(lens, "RgbFrame", 1.0),)),
               Component("gripper", "end_effector", "ParallelGripper", 0.3, hand, (SubComponent(jaw, "Finger", 1.0),))]
    parts, _ = body_pass(Oracle(ScriptedBackend(lambda q: pytest.fail(f"unexpected question {q.key}"))), tree, devices)
    by_joints = {p.joints[0]: (p.cls, p.confidence) for p in parts}
    assert by_joints[tool_neck[0]] == ("Arm", tool_share) and by_joints[camera_neck[0]] == ("Head", camera_share)
    assert [cls_conf for first, cls_conf in by_joints.items() if first not in (tool_neck[0], camera_neck[0])] == [("Arm", 1.0)]


@pytest.mark.parametrize("seed", [20, 21])
def test_the_eyes_a_head_turns_on_either_side_join_the_head(seed):
    """A neck (pan, tilt) carrying two eyes, each turning on its own joint on either side of the robot: the model
    calls all three heads, and they are one head, its eyes and all (on the code before: the eyes, lying on either
    side as two limbs do, were two more heads). Two arms below a chain called an arm stay apart."""
    w = Writer(random.Random(seed))
    trunk = w.link('<box size="0.3 0.4 0.6"/>')
    pan, tilt = w.link('<cylinder radius="0.04" length="0.05"/>'), w.link('<box size="0.15 0.2 0.15"/>')
    neck = [w.joint("revolute", trunk, pan, (0.0, 0.0, 0.35), (0.0, 0.0, 1.0)),
            w.joint("revolute", pan, tilt, (0.0, 0.0, 0.05), (0.0, 1.0, 0.0))]
    eyes = []
    for y in (0.05, -0.05):
        eye = w.link('<sphere radius="0.02"/>')
        eyes.append(w.joint("revolute", tilt, eye, (0.07, y, 0.03), (0.0, 0.0, 1.0)))
    tree = load_urdf(w.urdf())
    parts, _ = body_pass(Oracle(ScriptedBackend(lambda q: q.options[0] if q.key.startswith("side:") else "head")), tree, [])
    assert [(p.cls, sorted(p.joints)) for p in parts] == [("Head", sorted(neck + eyes))]


@pytest.mark.parametrize("seed", [18, 19])
def test_a_suspension_carrying_a_steered_wheel_is_a_joint_of_the_mobile_base(seed):
    """A car: each wheel on a suspension (a sliding joint), the front ones steered between them: the ontology makes a
    one-joint part carrying a joint of the mobile base one too, so each suspension joins the base unasked (on the
    code before: the front suspensions, carrying a steering joint rather than a wheel, were asked, and the model
    called one an arm)."""
    w = Writer(random.Random(seed))
    chassis, base_joints, wheels = w.link('<box size="0.9 0.4 0.15"/>'), [], []
    for x in (0.35, -0.25):
        for y in (0.2, -0.2):
            carrier, tyre = w.link(), w.link('<cylinder radius="0.1" length="0.06"/>')
            base_joints.append(w.joint("prismatic", chassis, carrier, (x, y, -0.07), (0.0, 0.0, -1.0), (-0.05, 0.05)))
            if x > 0:
                knuckle, carrier = carrier, w.link()
                base_joints.append(w.joint("revolute", knuckle, carrier, (0.0, 0.0, 0.0), (0.0, 0.0, 1.0), (-0.37, 0.37)))
            wheels.append(w.joint("continuous", carrier, tyre, (0.0, 0.0, 0.0), (0.0, 0.0, -1.0), rpy=(1.5708, 0.0, 0.0)))
    tree = load_urdf(w.urdf())

    def model(question):
        assert question.key.startswith("side:"), f"unexpected question {question.key}"
        return question.options[0]
    parts, _ = body_pass(Oracle(ScriptedBackend(model)), tree, [])
    [base] = [p for p in parts if p.cls == "MobileBase"]
    assert sorted(p.cls for p in parts) == ["MobileBase"] + ["Wheel"] * 4 and set(base.joints) == set(base_joints)


@pytest.mark.parametrize("seed", [16, 17])
def test_a_shank_drawn_out_from_its_unbounded_knee_is_no_wheel(seed):
    """Four limbs, each a motor spinning on a continuous joint and a shank on a knee written revolute with no limits
    (a simulator's file), the shank a box drawn centred 0.1 m out from the knee's axis: a body swung about its joint,
    no wheel (hands.wheel_body), so no knee is split off and settled a wheel, nor its motor a joint of a mobile base
    (on the code before: four wheels, each carried by a base joint). A wheel drawn round its axis stays a wheel."""
    w = Writer(random.Random(seed))
    trunk, limbs, shanks = w.link('<box size="0.4 0.2 0.08"/>'), [], []
    for x in (0.2, -0.2):
        for y in (0.12, -0.12):
            motor, thigh = w.link('<cylinder radius="0.04" length="0.03"/>'), w.link('<box size="0.01 0.01 0.11"/>')
            shank = w.link('<box size="0.01 0.01 0.2"/>', at=(0.0, 0.0, -0.1))
            hip = w.joint("continuous", trunk, motor, (x, y, 0.0), (0.0, 1.0, 0.0))
            w.joint("fixed", motor, thigh, (0.0, 0.0, -0.055))
            knee = w.joint("revolute", thigh, shank, (0.0, 0.0, -0.055), (0.0, 1.0, 0.0), unlimited=True)
            limbs.append([hip, knee])
            shanks.append(shank)
    wheel = w.link('<cylinder radius="0.05" length="0.02"/>', at=(0.0, 0.01, 0.0))
    w.joint("continuous", trunk, wheel, (0.0, 0.15, -0.1), (0.0, 1.0, 0.0))
    tree = load_urdf(w.urdf())
    assert not any(hands.wheel_body(tree, shank) for shank in shanks) and hands.wheel_body(tree, wheel)
    parts, _ = body_pass(Oracle(ScriptedBackend(lambda q: q.options[0] if q.key.startswith("side:") else "leg")), tree, [])
    assert sorted(list(p.joints) for p in parts if p.cls == "Leg") == sorted(limbs)
    assert sorted(p.cls for p in parts if p.cls != "Leg") == ["MobileBase", "Wheel"]  # the wheel on the trunk


@pytest.mark.parametrize("seed", [12, 13])
def test_a_second_motor_that_follows_a_joint_joins_that_joints_part(seed):
    """A six-joint arm whose shoulder and elbow each have a second motor written as a joint that follows them by
    <mimic> from the same link and moves nothing further (a dead-end link): the followers are no candidates of
    their own, so the arm is not cut at the shoulder into pieces the model would call heads, and their links join
    the arm (on the code before: three candidates more, each asked)."""
    w = Writer(random.Random(seed))
    base = w.link('<box size="0.4 0.4 0.2"/>')
    link, joints, followers = base, [], []
    for i, z in enumerate((0.2, 0.1, 0.3, 0.1, 0.25, 0.1)):
        child = w.link('<box size="0.05 0.05 0.2"/>')
        axis = (0.0, 0.0, 1.0) if i % 3 == 0 else (0.0, 1.0, 0.0)
        joints.append(w.joint("revolute", link, child, (0.0, 0.0, z), axis))
        if i in (1, 2):
            twin = w.link()
            w.joint("revolute", link, twin, (0.0, 0.0, z), axis, mimic=joints[-1])
            followers.append(twin)
        link = child
    tree = load_urdf(w.urdf())
    oracle = Oracle(ScriptedBackend(lambda q: pytest.fail(f"unexpected question {q.key}")))
    parts, _ = body_pass(oracle, tree, [])
    assert [(p.cls, p.joints) for p in parts] == [("Arm", tuple(joints))]
    assert set(followers) <= set(parts[0].links)


def test_a_wheel_with_a_contact_frame_on_its_rim_is_still_a_wheel_and_a_skid_steer_base_keeps_four():
    """Four wheels drawn as cylinders, each with a contact frame fixed on its rim, the rear ones following the front
    ones by <mimic> from the same chassis but another pivot: the front wheels spin a wheel's body, and each wheel is a
    wheel of its own (a follower off its joint's pivot and limb is no second motor)."""
    w = Writer(random.Random(9))
    base, wheels = w.link('<box size="0.6 0.4 0.1"/>'), []
    for y in (0.2, -0.2):
        front = None
        for x in (0.2, -0.2):
            wheel, contact = w.link('<cylinder radius="0.08" length="0.04"/>'), w.link()
            joint = w.joint("continuous", base, wheel, (x, y, 0.0), (0.0, 1.0, 0.0), mimic=front)
            w.joint("fixed", wheel, contact, (0.0, 0.0, -0.08))
            front = front or joint
            wheels.append(wheel)
    tree = load_urdf(w.urdf())
    front_wheels = wheels[::2]  # the rear ones follow them, so they do not spin on their own (Edge.spins)
    assert all(hands.wheel_body(tree, wheel) for wheel in front_wheels)
    assert not body._followers(tree, [e for e in tree.edges if e.movable])

    def rule(question):
        return question.options[0]
    parts, _ = body_pass(Oracle(ScriptedBackend(rule)), tree, [])
    assert sorted(p.cls for p in parts) == ["MobileBase"] + ["Wheel"] * 4


@pytest.mark.parametrize("seed", range(3))
def test_a_wheel_whose_tyre_is_fixed_on_its_hub_ends_a_leg_as_a_wheel(seed):
    """A wheel-legged biped's legs end in a motor rotor (a narrow cylinder) that the wheel joint turns, with the hub
    and the tyre (a wide cylinder) fixed on it and a ground-contact frame on the tyre's rim: the rotor, hub and tyre
    are one wheel's body, so each wheel joint is a wheel candidate of its own beside its leg, and the contact frames
    are the feet the robot stands on (they are no wheels of their own)."""
    w = Writer(random.Random(seed))
    trunk = w.link('<box size="0.2 0.3 0.1"/>')
    legs, spins, contacts, rotors = [], [], [], []
    for y in (0.1, -0.1):
        parent, leg = trunk, []
        for i in range(2):
            child = w.link('<box size="0.03 0.03 0.2"/>')
            leg.append(w.joint("revolute", parent, child, (0.0, y, 0.0) if not i else (0.0, 0.0, -0.2), (0, 1, 0)))
            parent = child
        rotor, hub, tyre, contact = (w.link('<cylinder radius="0.034" length="0.016"/>'), w.link(),
                                     w.link('<cylinder radius="0.05" length="0.04"/>'), w.link())
        spins.append(w.joint("continuous", parent, rotor, (0.0, 0.0, -0.2), (0, 0, 1), rpy=(1.5708, 0.0, 0.0)))
        w.joint("fixed", rotor, hub, (0.0, 0.0, 0.025))
        w.joint("fixed", hub, tyre, (0.0, 0.0, 0.021))
        w.joint("fixed", tyre, contact, (0.0, 0.047, 0.0))
        legs.append(tuple(leg))
        contacts.append(contact)
        rotors.append(rotor)
    tree = load_urdf(w.urdf())
    assert all(hands.wheel_body(tree, rotor) for rotor in rotors)
    assert _joints(body.chains(tree, set(), set())) == {*legs, *((spin,) for spin in spins)}
    assert hands.feet(tree) == set(contacts)


@pytest.mark.parametrize("seed", range(3))
def test_joints_that_move_bare_frames_alone_are_no_part(seed):
    """A mower's boundary-wire and collision sensor points are bare frames (a mass, nothing drawn), each on a
    continuous joint from the chassis so that a simulator keeps it: they move nothing of the body, so they are no
    wheels; the drive wheels beside them, a pan joint whose bare frame carries a camera, and a flipper's track drive
    (a bare frame on a continuous joint that a transmission drives) stay candidates."""
    w = Writer(random.Random(seed))
    chassis = w.link('<box size="0.6 0.4 0.2"/>')
    points = [w.joint("continuous", chassis, w.link(centre=(0.0, 0.0, 1.0), mass=0.01), (0.3, y, 0.0))
              for y in (-0.2, 0.0, 0.2)]
    wheels = [w.joint("continuous", chassis, w.link('<cylinder radius="0.1" length="0.04"/>'), (-0.2, y, -0.1),
                      (0, 1, 0)) for y in (-0.25, 0.25)]
    pan_frame, camera = w.link(), w.link('<box size="0.03 0.1 0.03"/>')
    pan = w.joint("revolute", chassis, pan_frame, (0.2, 0.0, 0.2))
    w.joint("fixed", pan_frame, camera, (0.02, 0.0, 0.0))
    flipper = w.link('<box size="0.3 0.05 0.1"/>')
    swing = w.joint("revolute", chassis, flipper, (-0.3, 0.25, 0.0), (0, 1, 0))
    drive = w.joint("continuous", flipper, w.link(centre=(0.0, 0.0, 0.0), mass=0.0001), axis=(0, 1, 0))
    urdf = w.urdf().replace(b"</robot>", f'<transmission name="t"><joint name="{drive}"/></transmission></robot>'.encode())
    tree = load_urdf(urdf)
    found = _joints(body.chains(tree, set(), set()))
    assert found == {(wheels[0],), (wheels[1],), (pan,), (swing,), (drive,)} and not {(p,) for p in points} & found
    assert _joints(body.chains(tree, set(), {camera})) == found  # the camera a device


def _joints(chains) -> set[tuple[str, ...]]:
    return {tuple(e.joint for e in c.joints) for c in chains}


def test_a_cylinder_off_the_axis_or_a_frame_beyond_it_along_the_axis_makes_no_wheel():
    """Only a cylinder drawn around the spinning joint's axis lets frames lie out to its rim, and only beside it
    along the axis: a servo ankle (written without limits) whose foot carries a round pad 3.5 cm below the axis and a
    sole frame under it, and a continuous wrist whose flange adapter is a cylinder on the axis with a tool point
    4 cm off the axis and 10 cm out along it, spin no wheel's body."""
    w = Writer(random.Random(3))
    shank, foot, pad, sole = (w.link('<box size="0.03 0.03 0.2"/>'), w.link('<box size="0.04 0.04 0.03"/>'),
                              w.link('<cylinder radius="0.05" length="0.01"/>'), w.link())
    w.joint("revolute", w.link('<box size="0.3 0.2 0.1"/>'), shank, (0.0, 0.1, 0.0), (0, 1, 0))
    w.joint("continuous", shank, foot, (0.0, 0.0, -0.2), (0, 1, 0))
    w.joint("fixed", foot, pad, (0.0, 0.0, -0.035))
    w.joint("fixed", pad, sole, (0.0, 0.0, -0.005))
    wrist, adapter, tip = w.link('<box size="0.05 0.05 0.05"/>'), w.link('<cylinder radius="0.05" length="0.02"/>'), w.link()
    w.joint("continuous", shank, wrist, (0.1, 0.0, 0.0), (0, 0, 1))
    w.joint("fixed", wrist, adapter, (0.0, 0.0, 0.01))
    w.joint("fixed", adapter, tip, (0.04, 0.0, 0.1))
    tree = load_urdf(w.urdf())
    assert not hands.wheel_body(tree, foot) and not hands.wheel_body(tree, wrist)


def test_a_drive_a_ros2_control_block_commands_and_an_undrawn_arm_keep_their_joints():
    """A flipper's track drive (a bare frame on a continuous joint) that a <ros2_control> block commands is driven as
    one a <transmission> names; an arm written for kinematics alone (masses, nothing drawn) keeps its joints: only a
    joint hung from a drawn body can move nothing."""
    w = Writer(random.Random(12))
    chassis, flipper = w.link('<box size="0.6 0.4 0.2"/>'), w.link('<box size="0.3 0.05 0.1"/>')
    swing = w.joint("revolute", chassis, flipper, (0.3, 0.25, 0.0), (0, 1, 0))
    drive = w.joint("continuous", flipper, w.link(centre=(0.0, 0.0, 0.0), mass=0.0001), axis=(0, 1, 0))
    link, arm = w.link(centre=(0.0, 0.0, 0.0)), []
    w.joint("fixed", chassis, link, (0.0, 0.0, 0.1))
    for i in range(6):
        child = w.link(centre=(0.0, 0.0, 0.05), mass=1.0)
        arm.append(w.joint("revolute", link, child, (0.0, 0.0, 0.1), (0, 0, 1) if i % 2 == 0 else (0, 1, 0)))
        link = child
    block = (f'<ros2_control name="tracks" type="system"><hardware><plugin>x</plugin></hardware><joint name="{drive}">'
             '<command_interface name="velocity"/><state_interface name="position"/></joint></ros2_control>')
    tree = load_urdf(w.urdf().replace(b"</robot>", block.encode() + b"</robot>"))
    assert next(e for e in tree.edges if e.joint == drive).driven
    assert {(swing,), (drive,), tuple(arm)} <= _joints(body.chains(tree, set(), set()))


def test_a_sensor_mount_without_range_carrying_the_housing_is_no_body_joint_where_other_joints_move():
    """A simulator's vehicle (thrusters spinning on the hull) mounts its camera housing on a revolute joint limited to
    0..0, the optical frame below it on another: the model took the housing for the mount, so the device owns only the
    optical frame. Nothing below moves and the file gives other joints their motion: a mount, no head. An arm
    exported with every joint 0..0 (SolidWorks' default) keeps its joints though its last one carries a camera."""
    w = Writer(random.Random(2))
    hull = w.link('<box size="1.0 0.4 0.3"/>')
    thrusters = [w.joint("continuous", hull, w.link('<cylinder radius="0.05" length="0.02"/>'), (-0.5, y, 0.0))
                 for y in (0.15, -0.15)]
    housing, optical = w.link('<box size="0.05 0.05 0.05"/>'), w.link()
    camera = w.joint("revolute", hull, housing, (0.5, 0.0, 0.0), limits=(0.0, 0.0))
    w.joint("revolute", housing, optical, rpy=(-1.5708, 0.0, -1.5708), limits=(0.0, 0.0))
    tree = load_urdf(w.urdf())
    assert _joints(body.chains(tree, set(), {optical})) == {(t,) for t in thrusters}
    assert camera not in {j for c in body.chains(tree, set(), {optical}) for j in (e.joint for e in c.joints)}
    w = Writer(random.Random(2))
    link, arm = w.link('<box size="0.3 0.3 0.1"/>'), []
    for i in range(6):
        child = w.link('<box size="0.05 0.05 0.2"/>')
        arm.append(w.joint("revolute", link, child, (0.0, 0.0, 0.2), (0, 0, 1) if i % 2 == 0 else (0, 1, 0), (0.0, 0.0)))
        link = child
    lens = w.link('<box size="0.03 0.03 0.03"/>')
    w.joint("fixed", link, lens, (0.0, 0.05, 0.1))
    tree = load_urdf(w.urdf())
    assert _joints(body.chains(tree, set(), {lens})) == {tuple(arm)}


def _camera(w: Writer, name: str, on: str) -> Component:
    """A camera body and its optical frame fixed on `on`, as the sensor pass would give it."""
    housing, optical = w.link('<box size="0.03 0.1 0.03"/>'), w.link()
    w.joint("fixed", on, housing, (0.05, 0.0, 0.0))
    w.joint("fixed", housing, optical)
    return Component(name, SENSOR, "MonocularCamera", 1.0, on,
                     (SubComponent(housing, "SensorHousing", 1.0), SubComponent(optical, "RgbFrame", 1.0)))


@pytest.mark.parametrize("seed", range(5))
def test_a_neck_branching_into_a_camera_unit_and_a_sensor_ring_is_one_head_and_a_hip_into_two_legs_three_legs(seed):
    """The model calls every candidate it is asked of a head (above) or a leg (below). A neck of two joints whose
    last link carries a pan-tilt camera unit and a turning ring with a camera (each of which the ontology settles as
    a head) is one head with them. A hip joint carrying a leg on either side stays a part of its own beside them:
    two chains of its class on either side of the robot are two limbs."""
    w = Writer(random.Random(seed))
    base = w.link('<box size="0.4 0.3 0.3"/>')
    neck = [w.link('<box size="0.05 0.05 0.1"/>'), w.link('<box size="0.1 0.1 0.1"/>')]
    neck_joints = [w.joint("revolute", base, neck[0], (0.0, 0.0, 0.3)),
                   w.joint("revolute", neck[0], neck[1], (0.0, 0.0, 0.1), (0.0, 1.0, 0.0))]
    unit, ring = w.link('<box size="0.1 0.15 0.1"/>'), w.link('<cylinder radius="0.1" length="0.02"/>')
    unit_joint = w.joint("revolute", neck[1], unit, (0.02, 0.0, 0.1), (0.0, 1.0, 0.0))
    ring_joint = w.joint("revolute", neck[1], ring, (0.0, 0.0, 0.05))
    components = [_camera(w, "unit_camera", unit), _camera(w, "ring_camera", ring)]
    hip = w.link('<box size="0.2 0.3 0.05"/>')
    hip_joint = w.joint("revolute", base, hip, (0.0, 0.0, -0.2))
    legs = []
    for y in (0.1, -0.1):
        link = hip
        joints: list[str] = []
        for z in (-0.05, -0.3, -0.3):
            child = w.link('<box size="0.05 0.05 0.3"/>')
            joints.append(w.joint("revolute", link, child, (0.0, y if not joints else 0.0, z), (0.0, 1.0, 0.0)))
            link = child
        legs.append(tuple(joints))
    tree = load_urdf(w.urdf())
    below = set(tree.descendants(hip))

    def rule(q):
        if q.key.startswith("side:"):
            return q.options[0]
        edge = next(e for e in tree.edges if e.joint == q.key[len("body:"):])
        return "leg" if edge.child in below or edge.child == hip else "head"
    parts, _ = body_pass(Oracle(ScriptedBackend(rule)), tree, components)
    assert sorted((p.cls, p.joints) for p in parts) == sorted([
        ("Head", (*neck_joints, unit_joint, ring_joint)), ("Leg", (hip_joint,)), ("Leg", legs[0]), ("Leg", legs[1])])


def _resting(seed: int, wheels: list[tuple[float, float]], arm: bool, panels: bool = False) -> tuple:
    """A drawn base carrying `wheels` (x, y) drawn as fixed cylinders of radius 0.1 resting on the ground (their
    centres 0.1 m up), a lidar on top and, with `arm`, a two-joint arm on a riser; the base is the root, or with
    `panels` hangs from a bare root frame beside two light drawn panels."""
    w = Writer(random.Random(seed))
    root = w.link() if panels else None
    base = w.link('<box size="0.6 0.4 0.2"/>', centre=(0.0, 0.0, 0.0), mass=30.0)
    if root is not None:
        w.joint("fixed", root, base, xyz=(0.0, 0.0, 0.1))
        for y in (0.25, -0.25):
            w.joint("fixed", root, w.link('<box size="0.5 0.02 0.1"/>', centre=(0.0, 0.0, 0.0), mass=0.5), xyz=(0.0, y, 0.1))
    fixed = []
    for x, y in wheels:
        wheel = w.link('<cylinder radius="0.1" length="0.04"/>', mass=0.5)
        w.joint("fixed", base, wheel, xyz=(x, y, 0.1), rpy=(1.5708, 0.0, 0.0))
        fixed.append(wheel)
    lidar = w.link('<cylinder radius="0.04" length="0.05"/>')
    w.joint("fixed", base, lidar, xyz=(0.2, 0.0, 0.25))
    if arm:
        riser, upper, fore = w.link('<box size="0.1 0.1 0.3"/>'), w.link('<box size="0.3 0.05 0.05"/>'), \
            w.link('<box size="0.3 0.05 0.05"/>')
        w.joint("fixed", base, riser, xyz=(0.0, 0.0, 0.35))
        w.joint("revolute", riser, upper, xyz=(0.0, 0.0, 0.2), axis=(0.0, 1.0, 0.0))
        w.joint("revolute", upper, fore, xyz=(0.3, 0.0, 0.0), axis=(0.0, 1.0, 0.0))
    return load_urdf(w.urdf()), lidar, fixed


@pytest.mark.parametrize("seed", range(3))
def test_a_main_body_resting_on_wheels_the_file_fixed_is_a_mobile_base_whatever_the_model_says(seed):
    """An omnidirectional base whose file writes its wheels as fixed links has no joint of its own and was given
    no part: resting on two or more cylinders of one radius on either side, it is a mobile base holding them, the
    model's share for mobile base its confidence (the model, asked, says none); the lidar on it is located there.
    Cylinders on one line (a snake's segments lying on the ground) are no wheels, and no question is asked."""
    asked = []

    def rule(question):
        asked.append(question.key)
        if question.key.startswith("body:") and "none" in question.options and len(question.options) == 2:
            return "none"
        return "arm" if question.key.startswith("body:") else question.options[0]
    tree, lidar, wheels = _resting(seed, [(0.2, 0.2), (0.2, -0.2), (-0.25, 0.0)], arm=seed % 2 == 0)
    sensor = Component(f"sensor_{lidar}", SENSOR, "Lidar", 0.9, tree.parent(lidar), (SubComponent(lidar, "SensingElement", 0.9),))
    parts, located = body_pass(Oracle(ScriptedBackend(rule)), tree, [sensor])
    bases = [p for p in parts if p.cls == "MobileBase"]
    assert len(bases) == 1 and bases[0].joints == () and set(bases[0].links) == {tree.root, *wheels}
    assert bases[0].confidence == 0.0 and located[0].located_on == bases[0].name
    assert any(p.cls == "Arm" for p in parts) == (seed % 2 == 0)
    tree, _, _ = _resting(seed, [(0.3, 0.0), (0.0, 0.0), (-0.3, 0.0)], arm=True)
    asked.clear()
    assert [p.cls for p in body_pass(Oracle(ScriptedBackend(rule)), tree, [])[0]] == ["Arm"]
    assert f"body:{tree.root}" not in asked


@pytest.mark.parametrize("seed", range(3))
def test_the_main_body_of_a_robot_with_no_joint_carrying_devices_is_a_mobile_base(seed):
    """A drone's airframe or a boat's hull carrying sensors, in a file with no movable joint (a frame above it
    carrying it beside lighter pieces): a mobile base standing for that body, whatever the model says; with no
    device on it, nothing is asked and no part made."""
    tree, lidar, _ = _resting(seed, [], arm=False, panels=True)
    hull = tree.parent(lidar)
    sensor = Component("lidar", SENSOR, "Lidar", 0.9, hull, (SubComponent(lidar, "SensingElement", 0.9),))
    asked = []

    def none(question):
        asked.append(question.key)
        return "none"
    parts, _ = body_pass(Oracle(ScriptedBackend(none)), tree, [sensor])
    assert [(p.cls, p.joints, p.links) for p in parts] == [("MobileBase", (), (hull,))] and len(asked) == 1
    assert body_pass(Oracle(ScriptedBackend(lambda q: pytest.fail("no question expected"))), tree, [])[0] == []


def _rotorcraft(seed: int, level: bool, gimbal: bool = False, held: int = 0) -> tuple:
    """A bare root frame carrying a drawn airframe, a camera under it (on a roll and pitch `gimbal`, or fixed) and
    four rotors drawn as thin discs spinning on continuous joints at the arms' tips, about the vertical, or
    (`level`) about a level axis near the ground, as wheels do; and `held` bare frames (an inertial unit's, an
    odometry plugin's) on the root by revolute joints limited 0..0, as RotorS writes them. (tree, camera component,
    airframe, rotors)"""
    rng = random.Random(seed)
    w = Writer(rng)
    root = w.link()
    frame = w.link('<box size="0.2 0.2 0.06"/>', centre=(0.0, 0.0, 0.0), mass=1.5)
    w.joint("fixed", root, frame)
    for _ in range(held):
        w.joint("revolute", root, w.link(), limits=(0.0, 0.0))
    arm = rng.uniform(0.08, 0.2)
    rotors = []
    for x, y in ((arm, -arm), (-arm, arm), (arm, arm), (-arm, -arm)):
        rotor = w.link('<cylinder radius="0.06" length="0.005"/>', centre=(0.0, 0.0, 0.0), mass=0.01)
        if level:
            w.joint("continuous", root, rotor, xyz=(x, y, -0.1), axis=(0.0, 0.0, 1.0), rpy=(1.5708, 0.0, 0.0))
        else:
            w.joint("continuous", root, rotor, xyz=(x, y, 0.03), axis=(0.0, 0.0, 1.0))
        rotors.append(rotor)
    camera = w.link('<box size="0.02 0.02 0.02"/>', mass=0.01)
    mount = root
    if gimbal:  # hung from the airframe
        mount = frame
        for axis in ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0)):
            ring = w.link('<box size="0.04 0.04 0.01"/>', mass=0.02)
            w.joint("revolute", mount, ring, xyz=(0.05, 0.0, -0.04) if mount == frame else (0.0, 0.0, 0.0), axis=axis)
            mount = ring
    w.joint("fixed", mount, camera, xyz=(0.05, 0.0, -0.04) if mount == root else (0.0, 0.0, -0.02))
    tree = load_urdf(w.urdf())
    sensor = Component("camera", SENSOR, "MonocularCamera", 0.9, mount, (SubComponent(camera, "RgbFrame", 0.9),))
    return tree, sensor, frame, rotors


@pytest.mark.parametrize("seed", range(4))
def test_rotors_spinning_about_the_vertical_are_no_wheels_and_leave_the_airframe_a_base(seed):
    """A drone's four rotors spin on continuous joints about the vertical: the ontology's Wheel turns about a level
    axis (core:turnsAboutVertical false), so no rotor is settled a wheel or offered one, and the model that calls
    anything a wheel where it may, none elsewhere, calls them none (they were four wheels at 1.0). Moving no body
    part, they leave the airframe carrying the camera the robot's main body, asked as a mobile base. The same discs spinning about a
    level axis near the ground are wheels by the ontology, whatever the model says."""
    tree, camera, frame, rotors = _rotorcraft(seed, level=False)
    offered: dict[str, tuple] = {}

    def wheel_or_base(question):
        offered[question.key] = question.options
        if question.key.startswith("side:"):
            return question.options[0]
        if question.key == f"body:{frame}":
            return "mobile base"
        return "wheel" if "wheel" in question.options else "none"
    parts, _ = body_pass(Oracle(ScriptedBackend(wheel_or_base)), tree, [camera])
    assert [(p.cls, p.joints, p.links) for p in parts] == [("MobileBase", (), (frame,))]
    rotor_questions = [options for key, options in offered.items() if key.startswith("body:") and key != f"body:{frame}"]
    assert len(rotor_questions) == 4 and not any("wheel" in options for options in rotor_questions)
    tree, camera, frame, rotors = _rotorcraft(seed, level=True)
    parts, _ = body_pass(Oracle(ScriptedBackend(lambda q: q.options[0] if q.key.startswith("side:") else "none")),
                         tree, [camera])
    assert sorted(p.cls for p in parts if p.cls == "Wheel") == ["Wheel"] * 4


@pytest.mark.parametrize("seed", range(3))
def test_sensor_frames_held_at_zero_beside_the_rotors_leave_the_airframe_a_base(seed):
    """A simulator's drone hangs its inertial and odometry frames, typed sensors, on revolute joints limited 0..0 from
    the root frame the airframe hangs from: those joints hold their frames still, so they move nothing and the
    airframe its rotors spin on is still the robot's main body, asked as a mobile base."""
    tree, camera, frame, _ = _rotorcraft(seed, level=False, held=2)
    held = [e.child for e in tree.edges if e.joint_type == "revolute" and e.limits == (0.0, 0.0)]
    sensors = [Component(f"imu_{k}", SENSOR, "IMU", 0.9, tree.root, (SubComponent(link, "SensingElement", 0.9),))
               for k, link in enumerate(held)]

    def rule(question):
        if question.key.startswith("side:"):
            return question.options[0]
        return "mobile base" if question.key == f"body:{frame}" else "none"
    parts, _ = body_pass(Oracle(ScriptedBackend(rule)), tree, [camera, *sensors])
    assert len(held) == 2 and [(p.cls, p.joints, p.links) for p in parts] == [("MobileBase", (), (frame,))]


def test_an_arm_written_0_0_in_a_file_giving_no_joint_a_range_still_moves_on_its_base():
    """A CAD export writes every joint 0..0: there the limits say nothing (KinematicTree.moving), so an arm's first
    joint on the base still moves it and the base is no jointless main body; in a file that gives another joint a
    range, the same 0..0 joints hold their links still."""
    def build(ranged: bool):
        w = Writer(random.Random(4))
        base = w.link('<box size="0.4 0.4 0.2"/>', mass=5.0)
        link = base
        for _ in range(3):
            child = w.link('<box size="0.05 0.05 0.2"/>')
            w.joint("revolute", link, child, (0.0, 0.0, 0.2), unwritten=True)
            link = child
        if ranged:
            w.joint("revolute", base, w.link('<box size="0.05 0.05 0.05"/>'), (0.1, 0.0, 0.1))
        return load_urdf(w.urdf()), base
    tree, base = build(ranged=False)
    assert body.main_body(tree, []) is None
    tree, base = build(ranged=True)
    assert body.main_body(tree, []) is None  # the ranged joint moves something on it
    assert body.main_body(tree, [], frozenset(e.joint for e in tree.edges if e.moves)) == base


@pytest.mark.parametrize("seed", range(3))
def test_a_chain_that_only_slides_is_offered_no_head(seed):
    """A mast lift slides a camera up, and a gantry's three sliding axes carry a wrist: by the ontology a head does
    not only slide and a wheel rolls (core:slidesOnly false on both), so neither chain is offered head or wheel,
    and the model that answers head wherever it may (a gantry was typed a head, 0.68) gives its next answer for
    both, torso; a pan joint carrying a camera is still offered head."""
    w = Writer(random.Random(seed))
    base = w.link('<box size="0.6 0.5 0.3"/>')
    mast = w.link('<box size="0.1 0.1 0.6"/>')
    lift = w.joint("prismatic", base, mast, (0.0, 0.0, 0.3), limits=(0.0, 0.5))
    camera = _camera(w, "camera", mast)
    link, gantry = base, []
    for axis in ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)):
        child = w.link('<box size="0.1 0.1 0.1"/>')
        gantry.append(w.joint("prismatic", link, child, (0.2, 0.0, 0.5) if link == base else (0.0, 0.0, 0.0),
                              axis, limits=(0.0, 0.8)))
        link = child
    pan = w.link('<box size="0.05 0.05 0.05"/>')
    w.joint("revolute", base, pan, (-0.2, 0.0, 0.3))
    other = _camera(w, "other_camera", pan)
    tree = load_urdf(w.urdf())
    offered: dict[str, tuple] = {}

    def rule(question):
        offered[question.key] = question.options
        if question.key.startswith("side:"):
            return question.options[0]
        return next(a for a in ("head", "torso", "arm") if a in question.options)
    parts, _ = body_pass(Oracle(ScriptedBackend(rule)), tree, [camera, other])
    classes = {p.joints[0]: p.cls for p in parts}
    assert "head" not in offered[f"body:{lift}"] and "wheel" not in offered[f"body:{gantry[0]}"]
    assert classes[lift] == "Torso" and classes[gantry[0]] == "Torso" and "head" not in offered[f"body:{gantry[0]}"]
    assert classes[next(p.joints[0] for p in parts if p.joints[0] not in (lift, *gantry))] == "Head"


@pytest.mark.parametrize("seed", range(3))
def test_an_airframe_carrying_a_camera_gimbal_is_still_asked_as_a_base(seed):
    """A drone's camera hangs on a roll and pitch gimbal, a head: a joint that moves a body part, so the airframe was
    asked nothing and given no part. Four rotors spin on it, moving no body part: it is the vehicle's main body,
    asked as a mobile base beside the gimbal's head."""
    tree, camera, frame, _ = _rotorcraft(seed, level=False, gimbal=True)

    def rule(question):
        if question.key.startswith("side:"):
            return question.options[0]
        if question.key == f"body:{frame}":
            return "mobile base"
        carries = "Carries: " in question.user and "camera" in question.user.split("Carries: ")[1]
        return "head" if carries and "head" in question.options else "none"
    parts, _ = body_pass(Oracle(ScriptedBackend(rule)), tree, [camera])
    assert sorted((p.cls, len(p.joints), p.links[:1]) for p in parts if p.cls == "MobileBase" or p.cls == "Head") \
        == [("Head", 2, parts[[p.cls for p in parts].index("Head")].links[:1]), ("MobileBase", 0, (frame,))]
    assert len(parts) == 2


@pytest.mark.parametrize("dummy", ["", '<box size="0.01 0.01 0.01"/>'])
@pytest.mark.parametrize("seed", range(3))
def test_a_body_the_file_moves_in_the_plane_by_virtual_joints_is_asked_as_a_base(seed, dummy):
    """A holonomic base written with no wheels: virtual x, y and yaw joints between bare frames (or dummy links drawn
    as 1 cm boxes) place its body, which carries a camera and a five-joint arm, or the camera alone (no candidate at
    all). Those joints place the whole robot, so no part holds them, and nothing else moves it about. Moved in the
    ground plane, the body is asked as a mobile base with no joint of its own, with or without the arm. Where the
    virtual joints also lift it (a vertical slide), they say nothing of the ground, and it is asked nothing."""
    def build(lift: bool, arm: bool = True):
        w = Writer(random.Random(seed))
        world, x, y = w.link(), w.link(dummy), w.link(dummy)
        w.joint("prismatic", world, x, axis=(1.0, 0.0, 0.0), limits=(-50.0, 50.0))
        w.joint("prismatic", x, y, axis=(0.0, 0.0, 1.0) if lift else (0.0, 1.0, 0.0), limits=(-50.0, 50.0))
        base = w.link('<box size="0.8 0.6 0.4"/>', mass=50.0)
        w.joint("continuous", y, base, axis=(0.0, 0.0, 1.0))
        camera = _camera(w, "camera", base)
        link = base
        for k in range(5 if arm else 0):
            child = w.link('<box size="0.05 0.05 0.2"/>')
            w.joint("revolute", link, child, (0.2, 0.0, 0.2) if link == base else (0.0, 0.0, 0.2),
                    (0.0, 1.0, 0.0) if k % 2 else (0.0, 0.0, 1.0))
            link = child
        return load_urdf(w.urdf()), camera, base

    asked: list[str] = []

    def rule(question):
        asked.append(question.key)
        if question.key.startswith("side:"):
            return question.options[0]
        return next(a for a in ("mobile base", "arm", "none") if a in question.options)
    tree, camera, base = build(lift=False)
    parts, _ = body_pass(Oracle(ScriptedBackend(rule)), tree, [camera])
    assert sorted((p.cls, p.joints, p.links) for p in parts if p.cls != "Arm") == [("MobileBase", (), (base,))]
    assert [p.cls for p in parts].count("Arm") == 1
    tree, camera, base = build(lift=False, arm=False)
    parts, _ = body_pass(Oracle(ScriptedBackend(rule)), tree, [camera])
    assert [(p.cls, p.joints, p.links) for p in parts] == [("MobileBase", (), (base,))]
    asked.clear()
    tree, camera, base = build(lift=True)
    parts, _ = body_pass(Oracle(ScriptedBackend(rule)), tree, [camera])
    assert f"body:{base}" not in asked and not any(p.cls == "MobileBase" for p in parts)


@pytest.mark.parametrize("seed", range(3))
def test_a_waist_carrying_an_arm_on_either_side_is_a_torso_whatever_the_model_says(seed):
    """A social robot's waist bends its upper body: two toolless two-joint arms on either side and a fixed head
    with a camera. The model, seeing the camera, calls the waist a head; the reasoner, once the arms are known,
    settles it a torso by what it carries (the model's share for torso its confidence). With both arms on one
    side, nothing settles it and the model's head stands."""
    def build(y_right: float):
        w = Writer(random.Random(seed))
        base, upper = w.link('<box size="0.5 0.5 0.3"/>'), w.link('<box size="0.3 0.3 0.5"/>')
        w.joint("revolute", base, upper, xyz=(0.0, 0.0, 0.6), axis=(0.0, 1.0, 0.0))
        head = w.link('<sphere radius="0.1"/>')
        w.joint("fixed", upper, head, xyz=(0.0, 0.0, 0.4))
        camera = _camera(w, "camera", head)
        shoulders = []
        for y in (0.2, y_right):
            shoulder, upper_arm, forearm = w.link(), w.link('<box size="0.05 0.05 0.25"/>'), \
                w.link('<box size="0.05 0.05 0.25"/>')
            w.joint("revolute", upper, shoulder, xyz=(0.0, y, 0.2), axis=(0.0, 1.0, 0.0))
            w.joint("revolute", shoulder, upper_arm, axis=(1.0, 0.0, 0.0))
            w.joint("fixed", upper_arm, forearm, xyz=(0.0, 0.0, -0.25))
            shoulders.append(shoulder)
        return load_urdf(w.urdf()), camera

    def rule(question):
        if question.key.startswith("side:"):
            return question.options[0]
        carries = "Carries: " in question.user and "camera" in question.user.split("Carries: ")[1]
        return "head" if carries else "arm"
    for y_right, waist in ((-0.2, "Torso"), (0.3, "Head")):
        tree, camera = build(y_right)
        parts, _ = body_pass(Oracle(ScriptedBackend(rule)), tree, [camera])
        assert sorted(p.cls for p in parts) == sorted(["Arm", "Arm", waist]), y_right


@pytest.mark.parametrize("length", [0.08, 1.0])
def test_cameras_at_the_end_of_long_links_do_not_make_a_head(length):
    """A two-joint chain on a post carrying a camera at its end: with links 0.08 m long it is a neck, a head by the
    ontology whatever the model says; with links a metre long (a tutorial's two-link arm carrying its camera and
    laser) its camera lies too far out for a head's, so the ontology settles nothing and the model's answer (here
    "arm") stands (on the code before: a head, settled at 1.0)."""
    w = Writer(random.Random(22))
    post = w.link('<box size="0.1 0.1 2.0"/>')
    first, second = w.link(f'<box size="0.05 0.05 {length}"/>'), w.link(f'<box size="0.05 0.05 {length}"/>')
    joints = [w.joint("continuous", post, first, (0.0, 0.1, 1.0), (0.0, 1.0, 0.0)),
              w.joint("continuous", first, second, (0.0, 0.1, length - 0.05), (0.0, 1.0, 0.0))]
    tip = w.link('<box size="0.05 0.05 0.05"/>')
    w.joint("fixed", second, tip, (0.0, 0.0, length - 0.05))
    camera = _camera(w, "camera", tip)
    tree = load_urdf(w.urdf())

    def rule(q):
        return q.options[0] if q.key.startswith("side:") else "arm"
    parts, _ = body_pass(Oracle(ScriptedBackend(rule)), tree, [camera])
    assert [(p.cls, list(p.joints)) for p in parts] == [("Head" if length < 0.5 else "Arm", joints)]


def test_a_sensor_held_back_under_the_floor_decides_no_body_part():
    """A small humanoid's torso carries a pan-tilt head with its camera and two three-joint arms whose forearms the
    model took for cameras it hardly believes in (0.05, under the floor: held back, never written). The held
    forearms own nothing and are carried by nothing: each arm keeps its elbow and is the model's to call an arm; the
    head alone carries a camera (on the code before: the arms, carrying a camera on three joints or fewer, were
    heads by the ontology, without their elbows)."""
    w = Writer(random.Random(3))
    torso = w.link('<box size="0.1 0.15 0.2"/>', centre=(0.0, 0.0, 0.0), mass=1.0)
    neck = w.link('<box size="0.02 0.02 0.03"/>', centre=(0.0, 0.0, 0.0), mass=0.05)
    pan = w.joint("revolute", torso, neck, (0.0, 0.0, 0.12), (0.0, 0.0, 1.0), (-2.0, 2.0))
    head = w.link('<box size="0.06 0.06 0.06"/>', centre=(0.0, 0.0, 0.0), mass=0.2)
    tilt = w.joint("revolute", neck, head, (0.0, 0.0, 0.03), (0.0, 1.0, 0.0), (-0.8, 1.5))
    lens = w.link()
    w.joint("fixed", head, lens, (0.03, 0.0, 0.0))
    arms, forearms = {}, {}
    for side, y in (("left", 0.09), ("right", -0.09)):
        shoulder = w.link('<box size="0.03 0.03 0.03"/>', centre=(0.0, 0.0, 0.0), mass=0.05)
        pitch = w.joint("revolute", torso, shoulder, (0.0, y, 0.08), (0.0, 1.0, 0.0), (-2.2, 2.2))
        humerus = w.link('<box size="0.03 0.03 0.14"/>', centre=(0.0, 0.0, -0.07), mass=0.1)
        roll = w.joint("revolute", shoulder, humerus, (0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (-0.3, 1.3))
        forearm = w.link('<box size="0.03 0.03 0.12"/>', centre=(0.0, 0.0, -0.06), mass=0.08)
        elbow = w.joint("revolute", humerus, forearm, (0.0, 0.0, -0.14), (0.0, 1.0, 0.0), (-2.8, 0.3))
        arms[side], forearms[side] = (pitch, roll, elbow), forearm
    legs = {}
    for side, y in (("left", 0.04), ("right", -0.04)):
        link, joints = torso, []
        for xyz, axis, size in (((0.0, y, -0.12), (0.0, 0.0, 1.0), 0.03), ((0.0, 0.0, -0.03), (1.0, 0.0, 0.0), 0.03),
                                ((0.0, 0.0, -0.03), (0.0, 1.0, 0.0), 0.14), ((0.0, 0.0, -0.14), (0.0, 1.0, 0.0), 0.14),
                                ((0.0, 0.0, -0.14), (0.0, 1.0, 0.0), 0.03), ((0.0, 0.0, -0.03), (1.0, 0.0, 0.0), 0.02)):
            child = w.link(f'<box size="0.03 0.03 {size}"/>', centre=(0.0, 0.0, -size / 2), mass=0.1)
            joints.append(w.joint("revolute", link, child, xyz, axis, (-1.5, 1.5)))
            link = child
        legs[side] = tuple(joints)
    tree = load_urdf(w.urdf())
    camera = Component("head camera", SENSOR, "MonocularCamera", 0.9, head, (SubComponent(lens, "RgbFrame", 0.9),))
    unsure = [Component(f"{side} forearm", SENSOR, "MonocularCamera", 0.05, tree.parent(forearm) or "",
                        (SubComponent(forearm, "RgbFrame", 0.9),)) for side, forearm in forearms.items()]

    def rule(question):
        if question.key.startswith("side:"):
            return question.options[0]
        return "head" if question.key == f"body:{pan}" else "leg" if question.key in leg_keys else "arm"
    leg_keys = {f"body:{joints[0]}" for joints in legs.values()}
    parts, _ = body_pass(Oracle(ScriptedBackend(rule)), tree, [camera, *unsure])
    found = {(p.cls, p.joints) for p in parts if p.joints}
    assert found == {("Head", (pan, tilt)), *(("Arm", joints) for joints in arms.values()),
                     *(("Leg", joints) for joints in legs.values())}
