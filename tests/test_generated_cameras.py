"""Generated camera heads (tests/camera_robots.py): group merging keeps each housing's frames together
and separate housings apart, even when the model calls every frame one device (all share a name stem).
Structure only, over hundreds of seeds: merge is called as the pipeline calls it, every frame mounted
on the head."""
from __future__ import annotations

import math
import random

import pytest
from tests.camera_robots import build
from tests.urdf_writer import Writer

from urdfkb.pipeline.abstraction.abstractor import SENSOR_PASS, Abstractor
from urdfkb.pipeline.reading.ingest import load_urdf
from urdfkb.pipeline.llm.scripted import ScriptedBackend
from urdfkb.pipeline.abstraction.oracle import Oracle
from urdfkb.pipeline.abstraction.stages.attachment import detect_roots, sub_chain
from urdfkb.pipeline.knowledge.ontology import vocabulary
from urdfkb.pipeline.abstraction.stages.classification import Typed
from urdfkb.pipeline.abstraction.stages.grouping import Group, merge, one_mount
from urdfkb.pipeline.abstraction.steps.classify import post_classification
from urdfkb.pipeline.abstraction.steps.findings import Findings
from urdfkb.pipeline.abstraction.frames import viewpoints

SEEDS = range(200)
TAX = vocabulary()


@pytest.mark.slow  # many generated robots
@pytest.mark.parametrize("bare", [False, True])
@pytest.mark.parametrize("seed", SEEDS)
def test_each_housing_is_one_device_whatever_the_names_share(seed, bare):
    """Housings facing apart are separate devices though every frame names one; a bare frame that a device's
    frames hang from is its housing as a box is (two lidars' own frames on one head)."""
    built = build(seed, bare)
    tree = load_urdf(built.urdf)
    frames = [frame for device in built.devices for frame in device]
    chains = [sub_chain(tree, frame, built.mount) for frame in frames]
    oracle = Oracle(ScriptedBackend(lambda q: built.stem))  # every frame: the same device
    groups = merge(oracle, tree, chains, "sensor", dict.fromkeys(frames, "VisionSensor"))
    assert sorted(sorted(g.leaves) for g in groups) == sorted(sorted(d) for d in built.devices), built.description


def test_the_generator_covers_lone_cameras_several_cameras_and_stereo_pairs():
    builds = [build(seed) for seed in SEEDS]
    assert {len(b.devices) for b in builds} >= {1, 2, 3, 4, 5}
    assert any(len({b.housing[f] for f in d}) == 2 for b in builds for d in b.devices)


@pytest.mark.slow  # many generated robots
def test_frames_on_one_body_are_one_device_whatever_the_names_say():
    """The model's mistake the other way: every frame named a device of its own (its whole name), as RGB-D
    cameras were split into one camera per frame. The frames of one housing are one device by structure;
    separate housings (a stereo pair's included, which only names join) stay apart."""
    for seed in SEEDS:
        built = build(seed)
        tree = load_urdf(built.urdf)
        frames = [frame for device in built.devices for frame in device]
        chains = [sub_chain(tree, frame, built.mount) for frame in frames]
        oracle = Oracle(ScriptedBackend(lambda q: q.options[-1]))  # the whole name: a device of its own
        groups = merge(oracle, tree, chains, "sensor", dict.fromkeys(frames, "VisionSensor"))
        by_housing: dict[str, list[str]] = {}
        for frame in frames:
            by_housing.setdefault(built.housing[frame], []).append(frame)
        assert sorted(sorted(g.leaves) for g in groups) == sorted(sorted(fs) for fs in by_housing.values()), \
            (seed, built.description)


@pytest.mark.slow  # many generated robots
def test_frames_of_one_body_mounted_apart_share_the_highest_mount_and_one_device():
    """The model mounts a housing's frames apart (one on the head, the others on the housing itself): they
    get one mount, the head, and group merging then keeps them one device whatever their names."""
    mounted_apart = 0
    for seed in SEEDS:
        built = build(seed)
        tree = load_urdf(built.urdf)
        frames = [frame for device in built.devices for frame in device]
        chains = [sub_chain(tree, frame, built.mount if k % 2 == 0 else built.housing[frame])
                  for k, frame in enumerate(frames)]
        chains = one_mount(tree, chains)
        by_housing: dict[str, list[str]] = {}
        for frame in frames:
            by_housing.setdefault(built.housing[frame], []).append(frame)
        for fs in by_housing.values():
            if len(fs) > 1 and any(frames.index(f) % 2 == 0 for f in fs):
                mounted_apart += 1
                assert {c.root for c in chains if c.leaf in fs} == {built.mount}, (seed, built.description)
        oracle = Oracle(ScriptedBackend(lambda q: q.options[-1]))
        groups = merge(oracle, tree, chains, "sensor", dict.fromkeys(frames, "VisionSensor"))
        for fs in by_housing.values():
            if {c.root for c in chains if c.leaf in fs} == {built.mount}:
                assert sorted(fs) in [sorted(g.leaves) for g in groups], (seed, built.description)
    assert mounted_apart  # some housing's frames were mounted apart


@pytest.mark.slow  # many generated robots
@pytest.mark.parametrize("bare", [False, True])
def test_frames_all_mounted_on_their_own_housing_are_mounted_on_its_parent_as_one_device(bare):
    """The model mounts every frame of a housing on the housing itself (a camera's own camera_link, bare or drawn as
    a box: a tracking camera's body carrying its two fisheye frames), where no device name can join them (the names
    they share begin the mount's): a body fixed to its parent that carries nothing but the device's frames is the
    device's own, so they are mounted on the link it is fixed to, and the housing binds them into one device."""
    for seed in SEEDS:
        built = build(seed, bare=bare)
        tree = load_urdf(built.urdf)
        frames = [frame for device in built.devices for frame in device]
        chains = one_mount(tree, [sub_chain(tree, frame, built.housing[frame]) for frame in frames])
        by_housing: dict[str, list[str]] = {}
        for frame in frames:
            by_housing.setdefault(built.housing[frame], []).append(frame)
        for fs in by_housing.values():
            if len(fs) > 1:
                assert {c.root for c in chains if c.leaf in fs} == {built.mount}, (seed, built.description)
        groups = merge(Oracle(ScriptedBackend(lambda q: q.options[-1])), tree, chains, "sensor",
                       dict.fromkeys(frames, "VisionSensor"))
        assert sorted(sorted(g.leaves) for g in groups) == sorted(sorted(fs) for fs in by_housing.values()), \
            (seed, built.description)


def test_a_body_carrying_more_than_the_frames_is_where_they_are_mounted():
    """A fixed head with a colour and a depth frame, and a lidar beside them: the head carries more than the camera's
    frames, so it is where the camera is mounted, not its housing."""
    w = Writer(random.Random(3))
    base = w.link('<box size="0.4 0.4 0.2"/>')
    head = w.link('<box size="0.1 0.2 0.1"/>')
    w.joint("fixed", base, head, (0.0, 0.0, 0.8))
    frames = [w.link(), w.link()]
    for k, frame in enumerate(frames):
        w.joint("fixed", head, frame, (0.05, 0.02 * k, 0.0), rpy=(-math.pi / 2, 0.0, -math.pi / 2))
    lidar = w.link('<cylinder radius="0.03" length="0.04"/>')
    w.joint("fixed", head, lidar, (0.0, 0.0, 0.08))
    tree = load_urdf(w.urdf())
    chains = one_mount(tree, [sub_chain(tree, frame, head) for frame in frames])
    assert {c.root for c in chains} == {head}


def _answer(prefer):
    """A scripted model that picks the first of `prefer` it is offered, else the first option."""
    def rule(q):
        return next((o for o in prefer if o in q.options), q.options[0])
    return rule


@pytest.mark.slow  # many generated robots
def test_a_stereo_pair_read_as_monocular_is_a_stereo_camera_and_a_lone_frame_no_stereo_camera():
    """The model reads a stereo pair as monocular cameras and calls any camera monocular where it may,
    stereo otherwise: the ontology's core:viewpointCount definitions (a monocular camera sees from one place,
    a stereo camera from two) and where the frames lie decide what it may say."""
    mono, stereo = TAX.answer("MonocularCamera"), TAX.answer("StereoCamera")
    seen = set()
    for seed in SEEDS:
        built = build(seed)
        tree = load_urdf(built.urdf)
        pair = next((d for d in built.devices if len({built.housing[f] for f in d}) == 2), None)
        lone = next((d for d in built.devices if len(d) == 1), None)
        groups = [Group([sub_chain(tree, f, built.mount) for f in d]) for d in (pair, lone) if d]
        state = Findings(groups=groups)
        state.pre = {f: Typed("MonocularCamera" if d is pair else "StereoCamera", 0.9)
                     for d in (pair, lone) if d for f in d}
        post_classification(Abstractor(Oracle(ScriptedBackend(_answer([mono, stereo]))), TAX).context(tree, kind="sensor"),
                            state)
        for group, typed in zip(groups, state.post):
            if group.leaves == pair:
                assert typed.cls == "StereoCamera", (seed, built.description)
                seen.add("pair")
            else:
                assert typed.cls == "MonocularCamera", (seed, built.description)
                seen.add("lone")
    assert seen == {"pair", "lone"}


@pytest.mark.slow  # many generated robots
def test_frames_of_one_housing_the_model_splits_between_sensor_and_tool_are_all_sensors():
    """The model calls one frame of a multi-frame housing part of an end-effector (0.52) and the others
    sensors (0.6): frames of one body are of one kind, the kind with more votes over them."""
    sensor, tool = TAX.answer(TAX.kinds["sensor"].cls), TAX.answer(TAX.kinds["end_effector"].cls)
    checked = 0
    for seed in SEEDS:
        built = build(seed)
        tree = load_urdf(built.urdf)
        by_housing: dict[str, list[str]] = {}
        for frame in (f for d in built.devices for f in d):
            by_housing.setdefault(built.housing[frame], []).append(frame)
        odd = {fs[0] for fs in by_housing.values() if len(fs) > 1}
        if not odd:
            continue
        def rule(q, odd=odd):
            return {tool: 0.52, sensor: 0.48} if q.key.split(":", 1)[1] in odd else {sensor: 0.6, tool: 0.4}
        abstractor = Abstractor(Oracle(ScriptedBackend(rule)), TAX)
        context, state = abstractor.context(tree, kind="sensor"), Findings()
        for step in SENSOR_PASS.steps[:2]:
            step(context, state)
        frames = [f for d in built.devices for f in d]
        assert {f: state.claims[f] for f in frames} == dict.fromkeys(frames, TAX.kinds["sensor"].cls), seed
        checked += 1
    assert checked > 50


@pytest.mark.slow  # many generated robots
def test_the_frames_of_one_housing_are_mounted_by_one_question():
    """Where the first frame of a housing is mounted on a link carrying the housing, its other frames are
    mounted there unasked (group merging would raise them to it anyway); frames of separate housings are asked."""
    for seed in SEEDS:
        built = build(seed)
        tree = load_urdf(built.urdf)
        frames = [f for d in built.devices for f in d]
        asked: list[str] = []

        def mount_on_head(q):
            asked.append(q.key)
            return built.mount
        chains = detect_roots(Oracle(ScriptedBackend(mount_on_head)), tree, frames, TAX.kinds["sensor"],
                              lambda _link: False, rigid=True)
        assert {c.root for c in chains} == {built.mount}, seed
        assert len(asked) == len(set(built.housing.values())), (seed, built.description)


MODALITY = {"rgb": "RgbFrame", "depth": "DepthFrame", "ir": "InfraredFrame"}


@pytest.mark.slow  # many generated robots
def test_the_frames_say_the_camera_whatever_the_model_names_it():
    """The model labels each frame's modality right but names every camera a depth camera where it may and
    monocular otherwise. The frames are typed first, and the ontology's definitions of the camera classes say
    which the device can be: colour and depth frames an RGB-D camera, depth frames alone a depth camera,
    colour frames seen from two places a stereo camera, from one a monocular camera."""
    depth, mono = TAX.answer("DepthCamera"), TAX.answer("MonocularCamera")
    seen = set()
    for seed in range(0, 200, 3):
        built = build(seed)
        tree = load_urdf(built.urdf)
        rng = random.Random(seed)
        devices = [d for d in built.devices if len(d) > 1 and len({built.housing[f] for f in d}) == 1]
        modality = {}
        for d in devices:
            mix = rng.choice([("rgb", "depth"), ("depth",), ("rgb",)])
            modality.update({f: mix[k % len(mix)] for k, f in enumerate(d)})

        def rule(q):
            leaf = q.key.split(":", 1)[1].split("@")[0]
            if q.key.startswith("part:"):
                return TAX.answer(MODALITY[modality[leaf]])
            return next((o for o in (depth, mono) if o in q.options), q.options[0])
        groups = [Group([sub_chain(tree, f, built.mount) for f in d]) for d in devices]
        state = Findings(groups=groups)
        state.pre = {f: Typed("MonocularCamera", 0.9) for d in devices for f in d}
        post_classification(Abstractor(Oracle(ScriptedBackend(rule)), TAX).context(tree, kind="sensor"), state)
        for d, typed in zip(devices, state.post):
            kinds = {modality[f] for f in d}
            expected = ("RGBDCamera" if kinds == {"rgb", "depth"} else "DepthCamera" if kinds == {"depth"}
                        else "StereoCamera" if (viewpoints(tree, d) or 1) > 1 else "MonocularCamera")
            assert typed.cls == expected, (seed, built.description, kinds)
            assert {f: state.parts[f].cls for f in d} == {f: MODALITY[modality[f]] for f in d}, seed
            seen.add(expected)
    assert seen == {"RGBDCamera", "DepthCamera", "StereoCamera"}


@pytest.mark.parametrize("seed", range(20))
def test_a_frame_further_along_the_line_of_sight_sees_from_the_same_place(seed):
    """Optical frames written at the lens and a centimetre ahead of it (an eye's two frames) are one viewpoint; two
    eyes side by side, across their lines of sight, are two, however the head is turned."""
    rng = random.Random(seed)
    w = Writer(rng)
    head = w.link('<box size="0.2 0.2 0.2"/>')
    yaw, baseline = rng.uniform(-math.pi, math.pi), rng.uniform(0.03, 0.12)
    eyes = []
    for side in (1.0, -1.0):
        eye = w.link()
        w.joint("fixed", head, eye, (0.1 * math.cos(yaw) - side * baseline / 2 * math.sin(yaw),
                                     0.1 * math.sin(yaw) + side * baseline / 2 * math.cos(yaw), 0.05), rpy=(0.0, 0.0, yaw))
        lens, ahead = w.link(), w.link()
        w.joint("fixed", eye, lens, (0.0, 0.0, 0.0), rpy=(-math.pi / 2, 0.0, -math.pi / 2))
        w.joint("fixed", eye, ahead, (rng.uniform(0.008, 0.03), 0.0, 0.0), rpy=(-math.pi / 2, 0.0, -math.pi / 2))
        eyes.append([lens, ahead])
    tree = load_urdf(w.urdf())
    assert [viewpoints(tree, frames) for frames in eyes] == [1, 1]
    assert viewpoints(tree, eyes[0] + eyes[1]) == 2


def _stereo_head(seed: int, declared: str) -> tuple[bytes, str, list[str]]:
    """A head with two camera housings 0.1 m apart looking forward, an optical frame under each. `declared`: "own",
    a simulator camera on each housing publishing in its own optical frame; "shared", the right one publishing in
    the left's (the Gazebo convention for a stereo pair); "multicamera", one declaration of both cameras on the left
    housing (SDF's multicamera). The URDF, the head and the two optical frames."""
    w = Writer(random.Random(seed))
    base, head = w.link('<box size="0.4 0.4 0.2"/>'), w.link('<box size="0.2 0.3 0.2"/>')
    w.joint("revolute", base, head, (0.0, 0.0, 0.5))
    frames, housings = [], []
    for y in (0.05, -0.05):
        housing, optical = w.link('<box size="0.03 0.03 0.03"/>'), w.link()
        w.joint("fixed", head, housing, (0.1, y, 0.05))
        w.joint("fixed", housing, optical, rpy=(-math.pi / 2, 0.0, -math.pi / 2))
        housings.append(housing)
        frames.append(optical)
    if declared == "multicamera":
        blocks = [(housings[0], "multicamera", frames[0])]
    else:
        blocks = [(h, "camera", frames[0] if declared == "shared" else f) for h, f in zip(housings, frames)]
    text = "".join(f'<gazebo reference="{h}"><sensor name="{h}_s" type="{kind}"><plugin name="{h}_p" '
                   f'filename="libgazebo_ros_camera.so"><frameName>{f}</frameName></plugin></sensor></gazebo>'
                   for h, kind, f in blocks)
    return w.urdf().replace(b"</robot>", text.encode() + b"</robot>"), head, frames


@pytest.mark.parametrize("seed", range(10))
def test_a_stereo_pair_declared_as_one_is_one_device_whatever_the_names_say(seed):
    """The model names each camera of a stereo pair a device of its own (a humanoid's stereo head became two
    monocular cameras). Where the right camera's declaration gives its images in the left camera's optical frame,
    or one declaration is of both cameras, the two are one device; where each publishes in its own frame, only
    names could join them."""
    for declared, devices in (("shared", 1), ("multicamera", 1), ("own", 2)):
        urdf, head, frames = _stereo_head(seed, declared)
        tree = load_urdf(urdf)
        chains = [sub_chain(tree, frame, head) for frame in frames]
        oracle = Oracle(ScriptedBackend(lambda q: q.options[-1]))  # the whole name: a device of its own
        groups = merge(oracle, tree, chains, "sensor", dict.fromkeys(frames, "VisionSensor"))
        assert len(groups) == devices, (seed, declared)


@pytest.mark.parametrize("seed", range(6))
def test_two_depth_cameras_each_declared_are_two_devices_whatever_the_names_say(seed):
    """A sensor head carries two depth cameras side by side looking the same way (bare frames, each with its optical
    frame and its own simulator depth camera) and a tracking camera's bare frame between them, declared nowhere. The
    model names every frame one device (a quadruped's two time-of-flight cameras and its tracking camera became
    one RGB-D camera): each declared depth image is a device of its own, as each declared ray sensor is."""
    w = Writer(random.Random(seed))
    base, head = w.link('<box size="0.6 0.3 0.1"/>'), w.link('<box size="0.1 0.25 0.1"/>')
    w.joint("fixed", base, head, (0.4, 0.0, 0.0))
    frames, depth, stem = [], [], w.name()
    for y in (0.095, 0.0, -0.095):
        housing, optical = w.link(), f"{stem}_{w.name()}"  # the frames' names share a stem
        w.links.append(f'<link name="{optical}"/>')
        w.joint("fixed", head, housing, (0.05, y, -0.05))
        w.joint("fixed", housing, optical, rpy=(-math.pi / 2, 0.0, -math.pi / 2))
        frames.append(optical)
        if y:
            depth.append((housing, optical))
    text = "".join(f'<gazebo reference="{h}"><sensor name="{h}_s" type="depth"><plugin name="{h}_p" '
                   f'filename="libgazebo_ros_openni_kinect.so"><frameName>{f}</frameName></plugin></sensor></gazebo>'
                   for h, f in depth)
    tree = load_urdf(w.urdf().replace(b"</robot>", text.encode() + b"</robot>"))
    chains = [sub_chain(tree, frame, base) for frame in frames]
    groups = merge(Oracle(ScriptedBackend(lambda q: q.options[0])), tree, chains, "sensor",
                   dict.fromkeys(frames, "VisionSensor"))
    declared = {optical for _, optical in depth}
    assert all(len(declared & set(g.leaves)) <= 1 for g in groups), (seed, [g.leaves for g in groups])
    assert sorted(f for g in groups for f in g.leaves) == sorted(frames)


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("turned", [False, True])
def test_colour_frames_beside_a_declared_rgbd_camera_are_its_own(seed, turned):
    """A head carries, as bare frames each with its optical frame, an RGB-D camera whose simulator declaration (a
    Kinect's openni plugin: colour and depth) is written on its depth frames, its colour frames 2.5 cm beside them,
    and a webcam 8 cm away on the other side, declared nowhere. The model names each frame a device of its own (a
    service robot's Kinect, under a shared namespace, became a monocular and an RGB-D camera): the colour frames are
    the declared camera's where they look the same way; the webcam and a colour frame turned aside stay apart."""
    w = Writer(random.Random(seed))
    base, head = w.link('<box size="0.4 0.4 0.2"/>'), w.link('<box size="0.2 0.3 0.2"/>')
    w.joint("revolute", base, head, (0.0, 0.0, 0.5))
    frames = []
    for y, yaw in ((0.0, 0.0), (0.025, 0.8 if turned else 0.0), (-0.08, 0.0)):  # depth, colour, webcam
        own, optical = w.link(), w.link()
        w.joint("fixed", head, own, (0.1, y, 0.05), rpy=(0.0, 0.0, yaw))
        w.joint("fixed", own, optical, rpy=(-math.pi / 2, 0.0, -math.pi / 2))
        frames.append((own, optical))
    (depth_own, depth), (_, colour), (_, webcam) = frames
    text = (f'<gazebo reference="{depth_own}"><sensor name="kinect" type="depth"><plugin name="kinect_p" '
            f'filename="libgazebo_ros_openni_kinect.so"><imageTopicName>rgb/image_raw</imageTopicName>'
            f'<depthImageTopicName>depth/image_raw</depthImageTopicName><frameName>{depth}</frameName></plugin>'
            '</sensor></gazebo>')
    tree = load_urdf(w.urdf().replace(b"</robot>", text.encode() + b"</robot>"))
    leaves = [f for _, f in frames]
    chains = [sub_chain(tree, frame, head) for frame in leaves]
    oracle = Oracle(ScriptedBackend(lambda q: q.options[-1]))  # the whole name: a device of its own
    groups = merge(oracle, tree, chains, "sensor", dict.fromkeys(leaves, "VisionSensor"))
    expected = [[depth], [colour], [webcam]] if turned else [[depth, colour], [webcam]]
    assert sorted(sorted(g.leaves) for g in groups) == sorted(sorted(e) for e in expected)


@pytest.mark.parametrize("seed", range(20))
def test_a_camera_written_as_one_body_keeps_its_kind_unless_it_is_one_eye_of_a_pair(seed):
    """A camera written as one body (a box, no optical frame) shows nowhere its imagers see from: the model's
    stereo reading of it stands, beside another camera looking the same way too. Two such bodies that are each
    other's mirror image across the robot's x-z plane, looking the same way, are the eyes of a pair, each a camera
    that sees from one place; bodies on the left and right looking out to either side are not."""
    rng = random.Random(seed)
    w = Writer(rng)
    base = w.link('<box size="0.6 0.4 0.3"/>')

    def body(xyz, yaw):
        link = w.link('<box size="0.03 0.1 0.03"/>')
        w.joint("fixed", base, link, xyz, rpy=(0.0, 0.0, yaw))
        return link

    x, y, z = rng.uniform(0.1, 0.3), rng.uniform(0.03, 0.1), rng.uniform(0.2, 0.5)
    lone = body((x, y, z), 0.0)
    beside = body((x + 0.01, 0.0, z + 0.03), 0.0)  # a camera of another kind at the centre, looking the same way
    eyes = [body((-x, side * y, z + 0.2), math.pi) for side in (1.0, -1.0)]  # a pair looking backwards
    out = [body((0.0, side * 0.2, z), side * math.pi / 2) for side in (1.0, -1.0)]  # looking out to either side
    stacked = [body((x, 0.0, z + 0.5 + dz), 0.0) for dz in (0.0, 0.012)]  # on the centre line, one above the other
    tree = load_urdf(w.urdf())
    links = [lone, beside, *eyes, *out, *stacked]
    groups = [Group([sub_chain(tree, link, base)]) for link in links]
    state = Findings(groups=groups)
    state.pre = {link: Typed("StereoCamera", 0.9) for link in links}
    mono = TAX.answer("MonocularCamera")
    post_classification(Abstractor(Oracle(ScriptedBackend(_answer([mono]))), TAX).context(tree, kind="sensor"), state)
    typed = {link: t.cls for link, t in zip(links, state.post)}
    assert typed == {lone: "StereoCamera", beside: "StereoCamera", eyes[0]: "MonocularCamera",
                     eyes[1]: "MonocularCamera", out[0]: "StereoCamera", out[1]: "StereoCamera",
                     stacked[0]: "StereoCamera", stacked[1]: "StereoCamera"}
    assert viewpoints(tree, [lone]) is None and viewpoints(tree, [eyes[0]], [eyes[1]]) == 1


@pytest.mark.parametrize("seed", range(20))
def test_bare_frames_straight_on_a_mount_are_one_device_only_where_they_look_the_same_way(seed):
    """Cameras written as bare frames fixed straight on the hull, which the model calls one device (every name
    shares a stem): frames looking the same way side by side (a colour and a depth frame in the optical convention and
    the camera's own frame, x forward, the camera level or pitched down) are one device; one looking ahead and one
    looking down or aside are two."""
    rng = random.Random(seed)
    w = Writer(rng)
    hull = w.link('<box size="1.0 0.3 0.3"/>')
    stem = w.name()
    x, tilt = rng.uniform(0.2, 0.5), rng.choice([0.0, rng.uniform(0.2, 0.9)])  # the camera pitched down or not
    optical_matrix = _matmul(_yaw(-math.pi / 2), _roll(-math.pi / 2))  # REP 103: z forward, x right, y down
    optical = _rpy(_matmul(_pitch(tilt), optical_matrix))

    def frame(xyz, rpy):
        name = f"{stem}_{w.name()}"
        w.links.append(f'<link name="{name}"/>')
        w.joint("fixed", hull, name, xyz, rpy=rpy)
        return name

    colour = frame((x, 0.01, 0.0), optical)
    depth = frame((x, -0.02, 0.0), optical)
    ahead = frame((x + 0.02, 0.0, 0.03), (0.0, tilt, 0.0))  # the device's own frame, x forward
    down = frame((x - 0.05, 0.0, -0.1), (0.0, tilt + rng.choice([0.8, 1.0, math.pi / 2]), 0.0))
    aside = frame((x - 0.1, 0.1, 0.0), (0.0, 0.0, rng.choice([1.0, math.pi / 2])))
    optical_aside = frame((x - 0.1, -0.1, 0.0), _rpy(_matmul(_yaw(-math.pi / 2), optical_matrix)))  # looking right
    tree = load_urdf(w.urdf())
    frames = [colour, depth, ahead, down, aside, optical_aside]
    chains = [sub_chain(tree, f, hull) for f in frames]
    groups = merge(Oracle(ScriptedBackend(lambda q: stem)), tree, chains, "sensor", dict.fromkeys(frames, "VisionSensor"))
    assert sorted(sorted(g.leaves) for g in groups) == sorted([sorted([colour, depth, ahead]), [down], [aside],
                                                               [optical_aside]])


@pytest.mark.parametrize("seed", range(4))
def test_scanners_at_either_end_of_a_vehicle_named_alike_are_two(seed):
    """A vehicle's front and rear scanners, each a drawn body with a bare frame written beside it on the chassis, all
    four named alike (the model gives them one device name): a bare frame is near only what lies within BARE_SPAN of
    it, so the front pair and the rear pair are two devices (on the code before: one lidar of four frames, the bare
    frames near everything on their mount)."""
    rng = random.Random(seed)
    w = Writer(rng)
    chassis = w.link('<box size="2.4 1.2 0.5"/>')
    stem = "scan_" + w.name()
    leaves = []
    for x, z in ((rng.uniform(0.8, 1.2), rng.uniform(0.3, 1.6)), (-rng.uniform(0.8, 1.2), 0.25)):
        for drawn in (True, False):
            name = f"{stem}_{w.name()}"
            shape = '<visual><geometry><cylinder radius="0.04" length="0.07"/></geometry></visual>' if drawn else ""
            w.links.append(f'<link name="{name}">{shape}</link>')
            w.joint("fixed", chassis, name, (x, 0.0, z))
            leaves.append(name)
    tree = load_urdf(w.urdf())
    chains = [sub_chain(tree, leaf, chassis) for leaf in leaves]
    groups = merge(Oracle(ScriptedBackend(lambda q: stem)), tree, chains, "sensor", dict.fromkeys(leaves, "RangingSensor"))
    assert sorted(sorted(g.leaves) for g in groups) == sorted([sorted(leaves[:2]), sorted(leaves[2:])])


def _roll(a: float) -> list[list[float]]:
    return [[1.0, 0.0, 0.0], [0.0, math.cos(a), -math.sin(a)], [0.0, math.sin(a), math.cos(a)]]


def _pitch(a: float) -> list[list[float]]:
    return [[math.cos(a), 0.0, math.sin(a)], [0.0, 1.0, 0.0], [-math.sin(a), 0.0, math.cos(a)]]


def _yaw(a: float) -> list[list[float]]:
    return [[math.cos(a), -math.sin(a), 0.0], [math.sin(a), math.cos(a), 0.0], [0.0, 0.0, 1.0]]


def _matmul(a: list[list[float]], b: list[list[float]]) -> list[list[float]]:
    return [[sum(a[i][k] * b[k][j] for k in range(3)) for j in range(3)] for i in range(3)]


def _rpy(m: list[list[float]]) -> tuple[float, float, float]:
    """URDF roll, pitch, yaw of a rotation matrix (R = Rz(yaw) Ry(pitch) Rx(roll))."""
    return math.atan2(m[2][1], m[2][2]), math.asin(-m[2][0]), math.atan2(m[1][0], m[0][0])


@pytest.mark.parametrize("seed", range(4))
def test_two_frames_at_one_point_of_a_body_are_one_device_however_far_its_origin_lies(seed):
    """A camera body fixed on an arm's last link, its origin on the wrist and its two bare frames at one point 0.12 m
    out (beyond CAMERA_BODY), turned apart, the model naming each its own device: frames at one point are one
    imager's, so they are one device mounted where the body is fixed (on the code before: two cameras)."""
    rng = random.Random(seed)
    w = Writer(rng)
    wrist, body = w.link('<box size="0.05 0.05 0.05"/>'), w.link('<box size="0.03 0.1 0.03"/>')
    w.joint("fixed", wrist, body)
    lens = (rng.uniform(0.11, 0.14), rng.uniform(-0.03, 0.03), -0.005)
    first, second = w.link(), w.link()
    w.joint("fixed", body, first, lens, rpy=(math.pi, 0.0, -math.pi / 2))
    w.joint("fixed", body, second, lens, rpy=(0.0, 0.0, math.pi / 2))
    tree = load_urdf(w.urdf())
    chains = one_mount(tree, [sub_chain(tree, first, body), sub_chain(tree, second, body)])
    assert {c.root for c in chains} == {wrist}
    groups = merge(Oracle(ScriptedBackend(lambda q: q.options[-1])), tree, chains, "sensor",
                   dict.fromkeys([first, second], "VisionSensor"))
    assert [sorted(g.leaves) for g in groups] == [sorted([first, second])]


OPTICAL = (-math.pi / 2, 0.0, -math.pi / 2)  # REP 103: an optical frame's z along its parent's x


@pytest.mark.parametrize("seed", range(10))
def test_a_cameras_inertial_frames_below_its_colour_frame_leave_it_one_device(seed):
    """A camera written with its inertial unit's frames (each an x-forward frame and its optical twin, as REP 103
    writes them) hung below its colour frame rather than beside it, on a housing with a depth frame: the colour
    frame carries one imager and its sensors, so the housing's frames are one device, though the model names each
    frame a device of its own (the L515 on a wrist and a base was split into three cameras)."""
    rng = random.Random(seed)
    w = Writer(rng)
    base, head = w.link('<box size="0.4 0.4 0.2"/>'), w.link('<box size="0.1 0.2 0.1"/>')
    w.joint("fixed", base, head, (0.0, 0.0, 0.5))
    housing = w.link('<box size="0.03 0.06 0.06"/>')
    w.joint("fixed", head, housing, (0.06, 0.0, 0.02))
    colour, depth = w.link(), w.link()
    w.joint("fixed", housing, colour, (0.0, 0.0, rng.uniform(0.01, 0.03)))
    w.joint("fixed", housing, depth, (0.0, 0.0, 0.0))
    leaves, categories = [], {}
    for parent, kind in ((colour, "VisionSensor"), (depth, "VisionSensor")):
        optical = w.link()
        w.joint("fixed", parent, optical, rpy=OPTICAL)
        leaves.append(optical)
        categories[optical] = kind
    offset = (rng.uniform(-0.005, 0.0), rng.uniform(-0.015, -0.01), rng.uniform(0.0, 0.003))
    for _ in range(2):  # gyroscope and accelerometer, at one point
        own, optical = w.link(), w.link()
        w.joint("fixed", colour, own, offset)
        w.joint("fixed", own, optical, rpy=OPTICAL)
        leaves.append(optical)
        categories[optical] = "InertialSensor"
    tree = load_urdf(w.urdf())
    chains = one_mount(tree, [sub_chain(tree, leaf, head) for leaf in leaves])
    oracle = Oracle(ScriptedBackend(lambda q: q.options[-1]))  # the whole name: a device of its own
    groups = merge(oracle, tree, chains, "sensor", categories)
    assert [sorted(g.leaves) for g in groups] == [sorted(leaves)]


def test_frames_on_a_tilting_cameras_own_frame_are_one_device():
    """A camera on a tilt motor, written as a bare frame the tilt joint moves, carrying the colour optical frame, the
    camera's housing and a depth frame with its optical twin: its frames are mounted on that frame, as the motion
    ends there, so no mount above it can gather them; the frame they all hang from is their body, so they are one
    device though the model names each a device of its own (a mobile manipulator's tilting RGB-D camera became
    three)."""
    w = Writer(random.Random(5))
    base, mast = w.link('<box size="0.4 0.4 0.2"/>'), w.link('<box size="0.04 0.04 0.3"/>')
    w.joint("fixed", base, mast, (0.0, 0.0, 0.25))
    tilted = w.link()
    w.joint("revolute", mast, tilted, (0.03, 0.0, 0.17), (0.0, 1.0, 0.0), limits=(-1.5, 1.5))
    colour, housing, depth, depth_optical = w.link(), w.link('<box size="0.07 0.28 0.07"/>'), w.link(), w.link()
    w.joint("fixed", tilted, colour, rpy=OPTICAL)
    w.joint("fixed", tilted, housing, (-0.03, 0.0, -0.016))
    w.joint("fixed", tilted, depth)
    w.joint("fixed", depth, depth_optical, rpy=OPTICAL)
    tree = load_urdf(w.urdf())
    leaves = [colour, housing, depth_optical]
    chains = one_mount(tree, [sub_chain(tree, leaf, tilted) for leaf in leaves])
    oracle = Oracle(ScriptedBackend(lambda q: q.options[-1]))
    groups = merge(oracle, tree, chains, "sensor", dict.fromkeys(leaves, "VisionSensor"))
    assert [sorted(g.leaves) for g in groups] == [sorted(leaves)]


@pytest.mark.parametrize("seed", range(6))
def test_frames_on_a_tilting_camera_housing_that_declares_the_camera_are_one_device(seed):
    """A camera's drawn housing on its tilt motor, on which the file declares the camera's simulator sensors (a depth
    and a colour camera), carrying bare frames alone: its depth, colour and inertial frames (two at one point, one a
    few centimetres aside), each named a device of its own by the model, are one device mounted on the housing
    (a humanoid's tilting RGB-D camera became two). A drawn head on a neck carrying the same frames, on which
    nothing is declared, leaves them to the names."""
    rng = random.Random(seed)
    w = Writer(rng)
    base = w.link('<box size="0.3 0.3 0.4"/>')
    housings = []
    for declared in (True, False):
        neck = w.link('<box size="0.03 0.03 0.03"/>')
        w.joint("revolute", base, neck, (0.0, 0.3 if declared else -0.3, 0.25), limits=(-1.0, 1.0))
        housing = w.link('<box size="0.025 0.09 0.025"/>')
        w.joint("revolute", neck, housing, (0.06, 0.0, 0.07), (0.0, 1.0, 0.0), limits=(-0.5, 0.5))
        housings.append(housing)
    frames = {}
    for housing in housings:
        side = rng.uniform(0.015, 0.025)
        frames[housing] = [w.link() for _ in range(3)]
        for frame, y in zip(frames[housing], (side, side, -side)):
            w.joint("fixed", housing, frame, (0.0075, y, 0.0))
    camera = housings[0]
    block = (f'<gazebo reference="{camera}"><sensor name="d" type="depth"><pose>0.0075 -0.0115 0 0 0 0</pose>'
             '<camera><image><width>640</width><height>480</height></image></camera></sensor>'
             '<sensor name="c" type="camera"><camera><image><width>640</width><height>480</height></image></camera>'
             '</sensor></gazebo>')
    tree = load_urdf(w.urdf().replace(b"</robot>", block.encode() + b"</robot>"))
    for housing, one in zip(housings, (True, False)):
        leaves = frames[housing]
        categories = dict(zip(leaves, ("VisionSensor", "InertialSensor", "VisionSensor")))
        chains = one_mount(tree, [sub_chain(tree, leaf, housing) for leaf in leaves])
        groups = merge(Oracle(ScriptedBackend(lambda q: q.options[-1])), tree, chains, "sensor", categories)
        assert (len(groups) == 1) == one, [g.leaves for g in groups]
        assert {c.root for g in groups for c in g.chains} == {housing}


def test_two_stereo_cameras_each_with_an_eye_below_the_other_stay_two_on_one_bar():
    """Two stereo cameras on one bare bar, each written as its left eye's frame carrying its optical frame and the
    right eye's frame a baseline below it: an eye hung below another's frame lies a baseline away, no built-in
    sensor of it, so each camera is one body of its own and the two stay apart, whatever the model names them."""
    w = Writer(random.Random(3))
    base, head = w.link('<box size="0.4 0.4 0.2"/>'), w.link('<box size="0.1 0.2 0.1"/>')
    w.joint("fixed", base, head, (0.0, 0.0, 0.5))
    bar = w.link()
    w.joint("fixed", head, bar, (0.05, 0.0, 0.08))
    cameras = []
    for z, baseline in ((0.03, 0.09), (-0.03, 0.06)):
        left, left_optical, right, right_optical = w.link(), w.link(), w.link(), w.link()
        w.joint("fixed", bar, left, (0.0, baseline / 2, z))
        w.joint("fixed", left, left_optical, rpy=OPTICAL)
        w.joint("fixed", left, right, (0.0, -baseline, 0.0))
        w.joint("fixed", right, right_optical, rpy=OPTICAL)
        cameras.append([left_optical, right_optical])
    tree = load_urdf(w.urdf())
    leaves = [leaf for camera in cameras for leaf in camera]
    chains = one_mount(tree, [sub_chain(tree, leaf, head) for leaf in leaves])
    groups = merge(Oracle(ScriptedBackend(lambda q: q.options[-1])), tree, chains, "sensor",
                   dict.fromkeys(leaves, "VisionSensor"))
    assert sorted(sorted(g.leaves) for g in groups) == sorted(sorted(c) for c in cameras)


def test_devices_on_a_bare_tilted_frame_that_see_from_two_places_stay_apart():
    """A pan-tilt unit whose tilted link is a bare frame, carrying two cameras 8 cm apart (each an own frame and its
    optical frame), or a head's two eyes and its inertial unit's frame: not a camera's own frame, which sees from
    one place, so each stays a device of its own whatever the model names it."""
    for eyes, inertial in ((0.04, False), (0.035, True)):
        w = Writer(random.Random(2))
        base, mast = w.link('<box size="0.4 0.4 0.2"/>'), w.link('<box size="0.04 0.04 0.3"/>')
        w.joint("fixed", base, mast, (0.0, 0.0, 0.25))
        pan, tilted = w.link('<box size="0.06 0.06 0.04"/>'), w.link()
        w.joint("revolute", mast, pan, (0.0, 0.0, 0.17), (0.0, 0.0, 1.0), limits=(-2.5, 2.5))
        w.joint("revolute", pan, tilted, (0.0, 0.0, 0.05), (0.0, 1.0, 0.0), limits=(-1.0, 1.0))
        devices, categories = [], {}
        for y in (eyes, -eyes):
            own, optical = w.link(), w.link()
            w.joint("fixed", tilted, own, (0.03, y, 0.0))
            w.joint("fixed", own, optical, rpy=OPTICAL)
            devices.append([optical])
            categories[optical] = "VisionSensor"
        if inertial:
            imu = w.link()
            w.joint("fixed", tilted, imu, (0.0, 0.0, 0.02))
            devices.append([imu])
            categories[imu] = "InertialSensor"
        tree = load_urdf(w.urdf())
        leaves = [leaf for d in devices for leaf in d]
        chains = one_mount(tree, [sub_chain(tree, leaf, tilted) for leaf in leaves])
        groups = merge(Oracle(ScriptedBackend(lambda q: q.options[-1])), tree, chains, "sensor", categories)
        assert sorted(sorted(g.leaves) for g in groups) == sorted(sorted(d) for d in devices), inertial


@pytest.mark.parametrize("seed", range(10))
def test_a_lone_optical_frame_gives_one_image_and_that_says_the_camera(seed):
    """The model calls cameras RGB-D where it may and reads each optical frame's image right. A housing with one
    optical frame below it (z along the housing's x: REP 103) gives one image: a colour one makes a monocular camera,
    a depth one a depth camera. A camera written as one body (a RealSense as one link) keeps the model's RGB-D: its
    one answer cannot show colour and depth together."""
    rng = random.Random(seed)
    w = Writer(rng)
    base = w.link('<box size="0.6 0.4 0.3"/>')
    frames, image = [], {}
    for kind in ("rgb", "depth"):
        housing = w.link('<box size="0.03 0.1 0.03"/>')
        w.joint("fixed", base, housing, (rng.uniform(0.1, 0.3), rng.uniform(-0.1, 0.1), rng.uniform(0.2, 0.5)))
        frames.append(w.link())
        w.joint("fixed", housing, frames[-1], rpy=(-math.pi / 2, 0.0, -math.pi / 2))
        image[frames[-1]] = kind
    body = w.link('<box size="0.03 0.1 0.03"/>')
    w.joint("fixed", base, body, (0.2, 0.0, 0.6))
    tree = load_urdf(w.urdf())
    rgbd = TAX.answer("RGBDCamera")

    def rule(q):
        leaf = q.key.split(":", 1)[1].split("@")[0]
        if q.key.startswith("part:"):
            return TAX.answer(MODALITY[image[leaf]])
        return next((o for o in (rgbd,) if o in q.options), q.options[0])
    groups = [Group([sub_chain(tree, link, base)]) for link in (*frames, body)]
    state = Findings(groups=groups)
    state.pre = {link: Typed("RGBDCamera", 0.9) for link in (*frames, body)}
    post_classification(Abstractor(Oracle(ScriptedBackend(rule)), TAX).context(tree, kind="sensor"), state)
    assert [t.cls for t in state.post] == ["MonocularCamera", "DepthCamera", "RGBDCamera"]
    assert {f: state.parts[f].cls for f in frames} == {f: MODALITY[image[f]] for f in frames}


@pytest.mark.parametrize("seed", range(6))
def test_a_bare_frame_where_a_lidars_base_is_is_that_lidar(seed):
    """A tower carries a lidar (its base, a cylinder, and its scan frame above it) and a bare frame fixed where the
    lidar's base is, turned as it is (the driver's frame name), beside a second lidar's base 0.2 m away. The model
    names every frame a device of its own: the bare frame is another name for the first lidar's base, one device;
    the second lidar, and a bare frame 1 cm off the first's base, stay devices of their own."""
    w = Writer(random.Random(seed))
    base, tower = w.link('<box size="0.6 0.4 0.2"/>'), w.link('<box size="0.1 0.1 0.4"/>')
    w.joint("fixed", base, tower, (-0.2, 0.0, 0.2))
    leaves = []
    for x in (0.0, 0.2):
        lidar, scan = w.link('<cylinder radius="0.05" length="0.07"/>'), w.link()
        w.joint("fixed", tower, lidar, (x, 0.0, 0.35))
        w.joint("fixed", lidar, scan, (0.0, 0.0, 0.04))
        leaves.append(scan)
    alias, apart = w.link(), w.link()
    w.joint("fixed", tower, alias, (0.0, 0.0, 0.35))
    w.joint("fixed", tower, apart, (0.0, 0.01, 0.35))
    tree = load_urdf(w.urdf())
    frames = [*leaves, alias, apart]
    chains = [sub_chain(tree, frame, tower) for frame in frames]
    oracle = Oracle(ScriptedBackend(lambda q: q.options[-1]))  # the whole name: a device of its own
    groups = merge(oracle, tree, chains, "sensor", dict.fromkeys(frames, "RangingSensor"))
    assert sorted(sorted(g.leaves) for g in groups) == sorted([sorted([leaves[0], alias]), [leaves[1]], [apart]])


def test_a_bare_frame_where_two_devices_links_are_names_neither():
    """Two lidars written with their macros' default pose, both bases at the tower's origin, and a bare frame there
    too: it could name either, so it joins neither."""
    w = Writer(random.Random(8))
    base, tower = w.link('<box size="0.6 0.4 0.2"/>'), w.link('<box size="0.1 0.1 0.4"/>')
    w.joint("fixed", base, tower, (-0.2, 0.0, 0.2))
    leaves = []
    for _ in range(2):
        lidar, scan = w.link('<cylinder radius="0.05" length="0.07"/>'), w.link()
        w.joint("fixed", tower, lidar)
        w.joint("fixed", lidar, scan, (0.0, 0.0, 0.04))
        leaves.append(scan)
    alias = w.link()
    w.joint("fixed", tower, alias)
    tree = load_urdf(w.urdf())
    frames = [*leaves, alias]
    chains = [sub_chain(tree, frame, tower) for frame in frames]
    oracle = Oracle(ScriptedBackend(lambda q: q.options[-1]))
    groups = merge(oracle, tree, chains, "sensor", dict.fromkeys(frames, "RangingSensor"))
    assert [alias] in [g.leaves for g in groups]


@pytest.mark.parametrize("pitch", [0.25, 0.5, 1.05])
def test_cameras_on_one_face_that_look_apart_are_two_devices(pitch):
    """A legged robot's face: a bare body (its mass alone) carrying a shell and two cameras, each its own frame and
    an optical frame below it, one looking ahead and one pitched down by `pitch` (14, 30 or 60 degrees): their lines of
    sight part, so they are two devices whatever the model names them (on the code before: one device, the face
    their body)."""
    w = Writer(random.Random(5))
    trunk, face = w.link('<box size="0.6 0.3 0.15"/>'), w.link(centre=(0.0, 0.0, 0.0), mass=0.5)
    w.joint("fixed", trunk, face, (0.35, 0.0, 0.0))
    w.joint("fixed", face, w.link('<box size="0.05 0.25 0.12"/>'), (0.0, 0.0, 0.0))
    devices = []
    for z, tilt in ((0.0, 0.0), (-0.06, pitch)):
        own, optical = w.link(centre=(0.0, 0.0, 0.0), mass=0.06), w.link()
        w.joint("fixed", face, own, (-0.02, 0.0, z), rpy=(0.0, tilt, 0.0))
        w.joint("fixed", own, optical, rpy=OPTICAL)
        devices.append([optical])
    tree = load_urdf(w.urdf())
    leaves = [d[0] for d in devices]
    chains = one_mount(tree, [sub_chain(tree, leaf, face) for leaf in leaves])
    groups = merge(Oracle(ScriptedBackend(lambda q: q.options[-1])), tree, chains, "sensor",
                   dict.fromkeys(leaves, "VisionSensor"))
    assert sorted(sorted(g.leaves) for g in groups) == sorted(devices)


def test_a_microphone_beside_a_camera_on_one_sensor_head_is_a_device_of_its_own():
    """A pan-tilt sensor head whose bare head frame carries a camera's optical frame and, 5 cm beside it, a frame the
    model called a microphone: frames of one body, and a camera's body binds its own inertial frames, but a
    microphone hears the room, not the camera, so it stays a device of its own (on the code before: the camera's)."""
    w = Writer(random.Random(9))
    base, pan, tilt, head = w.link('<box size="0.4 0.3 0.2"/>'), w.link('<box size="0.05 0.05 0.05"/>'), \
        w.link('<box size="0.05 0.05 0.05"/>'), w.link()
    w.joint("revolute", base, pan, (0.1, 0.0, 0.12), limits=(-2.0, 2.0))
    w.joint("revolute", pan, tilt, (0.0, 0.0, 0.05), (0.0, 1.0, 0.0), limits=(-1.0, 1.0))
    w.joint("fixed", tilt, head)
    camera, microphone = w.link(), w.link()
    w.joint("fixed", head, camera, (0.05, -0.02, 0.03), rpy=OPTICAL)
    w.joint("fixed", head, microphone, (0.05, 0.03, 0.03), rpy=OPTICAL)
    tree = load_urdf(w.urdf())
    chains = one_mount(tree, [sub_chain(tree, leaf, head) for leaf in (camera, microphone)])
    groups = merge(Oracle(ScriptedBackend(lambda q: q.options[-1])), tree, chains, "sensor",
                   {camera: "VisionSensor", microphone: "AudioSensor"})
    assert sorted(sorted(g.leaves) for g in groups) == sorted([[camera], [microphone]])


def _camera_block(link: str, i: int, fmt: str = "R8G8B8", cloud: bool = False) -> str:
    """A plain simulator camera on `link` giving `fmt` images; `cloud`: its plugin publishes a point cloud too."""
    topic = f"<pointCloudTopicName>c{i}/points</pointCloudTopicName>" if cloud else ""
    return (f'<gazebo reference="{link}"><sensor name="{link}_s{i}" type="camera"><camera><image><width>640</width>'
            f'<height>480</height><format>{fmt}</format></image></camera><plugin name="{link}_p{i}" '
            f'filename="libgazebo_ros_camera.so">{topic}</plugin></sensor></gazebo>')


@pytest.mark.parametrize("seed", range(10))
def test_a_camera_body_declaring_one_plain_image_is_no_rgbd_camera(seed):
    """The model calls cameras RGB-D where it may. A camera written as one body on which the file declares one plain
    simulator camera (SDF `camera`: one image, colour or infrared) gives one image, and an RGB-D camera needs two
    kinds: it is offered the other kinds. It stays RGB-D where that camera's plugin publishes a point cloud beside
    its image (the openni plugin on an old Gazebo's camera), where two cameras are declared on it (colour and
    infrared), where nothing is declared (a RealSense written as one link) and where its mesh names an RGB-D
    product of the catalogue."""
    rng = random.Random(seed)
    w = Writer(rng)
    base = w.link('<box size="0.6 0.4 0.3"/>')
    bodies = []
    for i in range(5):
        geometry = ('<mesh filename="package://p/meshes/d435.dae"/>' if i == 4 else '<box size="0.03 0.1 0.03"/>')
        bodies.append(w.link(geometry))
        w.joint("fixed", base, bodies[-1], (rng.uniform(0.1, 0.3), 0.2 * i - 0.4, rng.uniform(0.2, 0.5)))
    one, cloud, two, bare, product = bodies
    blocks = [_camera_block(one, 0), _camera_block(cloud, 1, cloud=True), _camera_block(two, 2),
              _camera_block(two, 3, fmt="L8"), _camera_block(product, 4)]
    tree = load_urdf(w.urdf().replace(b"</robot>", "".join(blocks).encode() + b"</robot>"))
    prefer = [TAX.answer("RGBDCamera"), TAX.answer("MonocularCamera")]
    groups = [Group([sub_chain(tree, link, base)]) for link in bodies]
    state = Findings(groups=groups)
    state.pre = {link: Typed("RGBDCamera", 0.9) for link in bodies}
    post_classification(Abstractor(Oracle(ScriptedBackend(_answer(prefer))), TAX).context(tree, kind="sensor"), state)
    assert [t.cls for t in state.post] == ["MonocularCamera", "RGBDCamera", "RGBDCamera", "RGBDCamera", "RGBDCamera"]
    assert tree.evidence[cloud].sensors[0].sdf_type == "rgbd_camera"


def _posed_camera_block(link: str, name: str, pose: tuple[float, ...], on_sensor: bool) -> str:
    """A plain simulator colour camera on `link` seeing from `pose` (x y z roll pitch yaw), written on the
    <sensor> or on its <camera>, as SDF allows either."""
    text = " ".join(f"{v:.4f}" for v in pose)
    return (f'<gazebo reference="{link}"><sensor name="{name}" type="camera">'
            + (f"<pose>{text}</pose>" if on_sensor else "") + "<camera>"
            + ("" if on_sensor else f"<pose>{text}</pose>")
            + '<image><width>1024</width><height>768</height><format>R8G8B8</format></image></camera>'
            f'<plugin name="{name}_p" filename="libgazebo_ros_camera.so"><frameName>{link}</frameName></plugin>'
            '</sensor></gazebo>')


@pytest.mark.parametrize("seed", range(8))
def test_a_camera_body_declaring_two_cameras_apart_is_a_stereo_camera(seed):
    """The model calls a camera written as one body monocular. Where the file declares on that body two simulator
    cameras seeing from two places a baseline apart (a stereo pair declared on its one link, as a rover's mast camera
    is), it sees from two places and is no monocular camera (core:viewpointCount); two declared at one place (a
    colour and a depth image of one imager) leave the model's word."""
    rng = random.Random(seed)
    w = Writer(rng)
    base = w.link('<box size="0.6 0.4 0.3"/>')
    pair, one_place = w.link('<box size="0.04 0.16 0.04"/>'), w.link('<box size="0.04 0.16 0.04"/>')
    w.joint("fixed", base, pair, (0.25, 0.1, rng.uniform(0.2, 0.5)), rpy=(0.0, rng.uniform(0.0, 0.6), 0.0))
    w.joint("fixed", base, one_place, (0.25, -0.1, 0.3))
    half = rng.uniform(0.03, 0.1)
    on_sensor = rng.random() < 0.5
    at = (rng.uniform(-0.01, 0.01), 0.0, 0.0)
    blocks = [_posed_camera_block(pair, f"eye{k}", (at[0], y, 0.0, 0.0, 0.0, 0.0), on_sensor)
              for k, y in enumerate((half, -half))]
    blocks += [_posed_camera_block(one_place, f"img{k}", (0.01, 0.02, 0.0, 0.0, 0.0, 0.0), on_sensor)
               for k in range(2)]
    tree = load_urdf(w.urdf().replace(b"</robot>", "".join(blocks).encode() + b"</robot>"))
    assert viewpoints(tree, [pair]) == 2 and viewpoints(tree, [one_place]) is None
    groups = [Group([sub_chain(tree, link, base)]) for link in (pair, one_place)]
    state = Findings(groups=groups)
    state.pre = {link: Typed("MonocularCamera", 0.9) for link in (pair, one_place)}
    prefer = [TAX.answer("MonocularCamera"), TAX.answer("StereoCamera")]
    post_classification(Abstractor(Oracle(ScriptedBackend(_answer(prefer))), TAX).context(tree, kind="sensor"), state)
    assert [t.cls for t in state.post] == ["StereoCamera", "MonocularCamera"]


@pytest.mark.parametrize("seed", range(4))
def test_a_camera_declared_on_one_frame_writing_its_images_in_another_is_one_imager(seed):
    """A camera declared on a small frame whose plugin writes its images in a second frame hung beside it (an eye
    that turns both: the declared frame a few centimetres behind the eye's origin, the image frame at it, turned to
    the optical convention's axes): the two are one imager, seeing from one place, so no stereo camera (on the code
    before: two places, a stereo camera settled at 1.0); the model's monocular stands."""
    rng = random.Random(seed)
    w = Writer(rng)
    base = w.link('<box size="0.6 0.4 0.3"/>')
    eye = w.link('<sphere radius="0.03"/>')
    w.joint("revolute", base, eye, (0.2, rng.choice((0.05, -0.05)), 0.8), (0.0, 0.0, 1.0), (-1.0, 1.0))
    declared, image = w.link('<box size="0.001 0.001 0.001"/>'), w.link('<box size="0.001 0.001 0.001"/>')
    w.joint("fixed", eye, declared, (-rng.uniform(0.02, 0.04), 0.0, 0.0), rpy=(0.0, math.pi, 0.0))
    w.joint("fixed", eye, image, rpy=(math.pi / 2, 0.0, -math.pi / 2))
    block = (f'<gazebo reference="{declared}"><sensor name="eye" type="camera"><camera><image><width>640</width>'
             '<height>480</height><format>R8G8B8</format></image></camera><plugin name="eye_p" '
             f'filename="libgazebo_ros_camera.so"><frameName>{image}</frameName></plugin></sensor></gazebo>')
    tree = load_urdf(w.urdf().replace(b"</robot>", block.encode() + b"</robot>"))
    assert viewpoints(tree, [declared, image]) == 1 and viewpoints(tree, [declared]) is None
    state = Findings(groups=[Group([sub_chain(tree, declared, eye), sub_chain(tree, image, eye)])])
    state.pre = {link: Typed("MonocularCamera", 0.9) for link in (declared, image)}
    prefer = [TAX.answer("MonocularCamera"), TAX.answer("StereoCamera")]
    post_classification(Abstractor(Oracle(ScriptedBackend(_answer(prefer))), TAX).context(tree, kind="sensor"), state)
    assert [t.cls for t in state.post] == ["MonocularCamera"]


@pytest.mark.parametrize("turned", [False, True])
@pytest.mark.parametrize("bracket_mesh, devices", [("sensors/xtion_pro_stack", 1), ("sensors/d435_bracket", 2)])
def test_a_bracket_drawn_with_the_products_mesh_beside_its_camera_is_part_of_it(bracket_mesh, devices, turned):
    """A camera's frames and body hang from a bare frame on the base; its mounting bracket, a lone drawn leaf whose
    mesh names the same product (an Xtion's stack mount), is fixed beside it, its frame turned as the camera's or on
    its side (a mesh exported with y up). Asked apart, each keeps its own name; naming one product, the bracket is a
    piece of that camera however it is turned. A bracket naming another product stays apart."""
    w = Writer(random.Random(3))
    base = w.link('<box size="0.4 0.4 0.1"/>')
    frame = w.link()
    w.joint("fixed", base, frame, xyz=(-0.09, 0.02, 0.3))
    body = w.link('<mesh filename="package://d/meshes/sensors/xtion_pro_camera.dae"/>')
    w.joint("fixed", frame, body, xyz=(0.0, -0.02, 0.0))
    optical, depth = w.link(), w.link()
    w.joint("fixed", frame, optical, rpy=(-math.pi / 2, 0.0, -math.pi / 2))
    w.joint("fixed", frame, depth, xyz=(0.0, -0.025, 0.0), rpy=(-math.pi / 2, 0.0, -math.pi / 2))
    bracket = w.link(f'<mesh filename="package://d/meshes/{bracket_mesh}.dae"/>')
    w.joint("fixed", base, bracket, xyz=(-0.1, 0.0, 0.28), rpy=(math.pi / 2, 0.0, -math.pi / 2) if turned else (0.0, 0.0, 0.0))
    tree = load_urdf(w.urdf())
    leaves = [body, optical, depth, bracket]
    chains = [sub_chain(tree, leaf, base) for leaf in leaves]
    groups = merge(Oracle(ScriptedBackend(lambda q: q.options[-1])), tree, chains, "sensor",
                   dict.fromkeys(leaves, "VisionSensor"))
    assert len(groups) == devices and any(set(g.leaves) >= {body, optical, depth} for g in groups)


def _depth_device(w: Writer, mount: str, prefix: str, y: float, colour: bool) -> tuple[list[str], str]:
    """A RealSense as its ROS description package writes it: a body link on `mount`, each imager's frame below it
    with its optical frame, and on the body the simulator sensors its Gazebo macro declares for every model (a
    colour camera, two infrared cameras, a depth camera); a colour imager only where `colour`. Its optical frames
    and the <gazebo> block."""
    w.links.append(f'<link name="{prefix}_link"><visual><geometry><box size="0.025 0.09 0.025"/></geometry></visual>'
                   '</link>')
    w.joint("fixed", mount, f"{prefix}_link", xyz=(0.2, y, 0.3))
    optical = []
    for k, imager in enumerate(["depth", "left_ir", "right_ir"] + ["color"] * colour):
        frame, lens = f"{prefix}_{imager}_frame", f"{prefix}_{imager}_optical_frame"
        w.links += [f'<link name="{frame}"/>', f'<link name="{lens}"/>']
        w.joint("fixed", f"{prefix}_link", frame, xyz=(0.0, 0.05 - 0.015 * k, 0.0))
        w.joint("fixed", frame, lens, rpy=(-math.pi / 2, 0.0, -math.pi / 2))
        optical.append(lens)
    images = [("color", "camera", "RGB_INT8"), ("ired1", "camera", "L_INT8"), ("ired2", "camera", "L_INT8"),
              ("depth", "depth", "")]
    return optical, f'<gazebo reference="{prefix}_link">' + "".join(
        f'<sensor name="{prefix}{name}" type="{kind}"><camera><image><width>640</width><height>480</height>'
        + (f"<format>{fmt}</format>" if fmt else "") + "</image></camera></sensor>"
        for name, kind, fmt in images) + "</gazebo>"


def test_a_depth_module_the_links_name_is_a_depth_camera_whatever_its_simulator_macro_declares():
    """The model calls cameras RGB-D where it may, and reads each frame's modality right. Two RealSense devices in
    the layout of their description package, whose simulator macro declares a colour camera for every model: a D435
    (colour, depth and two infrared imagers) is an RGB-D camera; a D430 depth module (no colour imager, the
    catalogue's depth camera) is a depth camera, the links' product outweighing the macro's colour camera."""
    w = Writer(random.Random(5))
    base = w.link('<box size="0.5 0.4 0.3"/>')
    d435, front = _depth_device(w, base, "front_realsense_d435", 0.1, colour=True)
    d430, rear = _depth_device(w, base, "rear_realsense_d430", -0.1, colour=False)
    tree = load_urdf(w.urdf().replace(b"</robot>", (front + rear).encode() + b"</robot>"))
    modality = {"depth": "DepthFrame", "left": "InfraredFrame", "right": "InfraredFrame", "color": "RgbFrame"}

    def rule(q):
        if q.key.startswith("part:"):
            leaf = q.key.split(":", 1)[1].split("@")[0]
            kind = next(v for k, v in modality.items() if f"_{k}_" in leaf)
            return TAX.answer(kind)
        return next((o for o in (TAX.answer("RGBDCamera"),) if o in q.options), q.options[0])
    groups = [Group([sub_chain(tree, f, base) for f in frames]) for frames in (d435, d430)]
    state = Findings(groups=groups)
    state.pre = {f: Typed("RGBDCamera", 0.9) for f in d435 + d430}
    post_classification(Abstractor(Oracle(ScriptedBackend(rule)), TAX).context(tree, kind="sensor"), state)
    assert [t.cls for t in state.post] == ["RGBDCamera", "DepthCamera"]


def test_the_imagers_of_one_camera_tilted_a_few_degrees_apart_stay_one_device():
    """A time-of-flight RGB-D camera's depth imager is tilted up to 8 degrees from its colour imager (a Femto Bolt's,
    an Azure Kinect's 6): the two optical frames below the camera's bare body are still one device's."""
    w = Writer(random.Random(8))
    trunk, body = w.link('<box size="0.6 0.3 0.15"/>'), w.link()
    w.joint("fixed", trunk, body, (0.3, 0.0, 0.1))
    frames = []
    for y, tilt in ((0.016, 0.0), (-0.016, math.radians(8))):
        own, optical = w.link(), w.link()
        w.joint("fixed", body, own, (0.0, y, 0.0), rpy=(0.0, tilt, 0.0))
        w.joint("fixed", own, optical, rpy=OPTICAL)
        frames.append(optical)
    tree = load_urdf(w.urdf())
    chains = one_mount(tree, [sub_chain(tree, leaf, body) for leaf in frames])
    groups = merge(Oracle(ScriptedBackend(lambda q: q.options[-1])), tree, chains, "sensor",
                   dict.fromkeys(frames, "VisionSensor"))
    assert sorted(sorted(g.leaves) for g in groups) == [sorted(frames)]


@pytest.mark.parametrize("seed", range(6))
def test_a_depth_frame_beside_its_optical_twin_on_a_tilt_link_is_the_cameras(seed):
    """A pan-tilt head's drawn tilt link carrying, straight on it at one point, a colour and a depth optical frame
    and the depth imager's x-forward frame (as a hexapod's head writes its RGB-D camera), the model naming that
    x-forward frame a device of its own: it looks along the optical frames' line of sight from their point, so it is
    their imager's frame and the three are one device; a frame at that point looking aside stays apart (on the code
    before: an RGB-D camera and a depth camera)."""
    rng = random.Random(seed)
    w = Writer(rng)
    base, pan, tilt = w.link('<box size="0.3 0.3 0.1"/>'), w.link('<box size="0.05 0.05 0.05"/>'), \
        w.link('<box size="0.04 0.1 0.04"/>')
    w.joint("revolute", base, pan, (0.1, 0.0, 0.1))
    w.joint("revolute", pan, tilt, (0.0, 0.0, 0.05), (0.0, 1.0, 0.0))
    at = (rng.uniform(0.0, 0.03), rng.uniform(-0.02, 0.02), rng.uniform(0.0, 0.03))
    colour, depth, body, aside = w.link(), w.link(), w.link(), w.link()
    w.joint("fixed", tilt, colour, at, rpy=OPTICAL)
    w.joint("fixed", tilt, depth, at, rpy=OPTICAL)
    w.joint("fixed", tilt, body, at)
    w.joint("fixed", tilt, aside, at, rpy=(0.0, 0.0, math.pi / 2))
    tree = load_urdf(w.urdf())
    leaves = [colour, depth, body, aside]
    names = {colour: "camera", depth: "camera", body: "camera_depth", aside: "aside"}

    def rule(q):
        leaf = q.key.split(":", 1)[1]
        return names[leaf] if names[leaf] in q.options else q.options[-1]
    groups = merge(Oracle(ScriptedBackend(rule)), tree, [sub_chain(tree, leaf, tilt) for leaf in leaves], "sensor",
                   dict.fromkeys(leaves, "VisionSensor"))
    assert sorted(sorted(g.leaves) for g in groups) == sorted([sorted([colour, depth, body]), [aside]])


@pytest.mark.parametrize("seed", range(6))
def test_cameras_on_one_rack_facing_apart_are_devices_of_their_own_whatever_the_names_say(seed):
    """A drawn sensor rack carrying camera bodies a metre apart, each turned its own way with its optical frame, and
    a stereo bar of two lens bodies side by side: mounted on the link the rack is fixed to and all named "camera" by
    the model, the cameras facing apart stay apart (their own bodies, below the rack they share, lie apart), and the
    two lenses side by side stay one device (on the code before: the rack joined every camera to the next)."""
    rng = random.Random(seed)
    w = Writer(rng)
    base, rack = w.link('<box size="2.0 1.0 0.5"/>'), w.link('<box size="1.8 0.2 0.05"/>')
    w.joint("fixed", base, rack, (0.0, 0.0, 0.5))
    singles = []
    for yaw in (0.0, math.pi / 2, math.pi, -math.pi / 2):
        body, optical = w.link('<box size="0.05 0.05 0.05"/>'), w.link()
        w.joint("fixed", rack, body, (math.cos(yaw) * 0.8, math.sin(yaw) * 0.8, 0.05 + 0.01 * rng.random()),
                rpy=(0.0, 0.0, yaw + rng.uniform(-0.1, 0.1)))
        w.joint("fixed", body, optical, rpy=OPTICAL)
        singles.append(optical)
    bar = w.link('<box size="0.03 0.2 0.03"/>')
    w.joint("fixed", rack, bar, (0.3, 0.0, 0.1))
    pair = []
    for y in (0.06, -0.06):
        lens, optical = w.link('<cylinder radius="0.01" length="0.02"/>'), w.link()
        w.joint("fixed", bar, lens, (0.02, y, 0.0))
        w.joint("fixed", lens, optical, rpy=OPTICAL)
        pair.append(optical)
    urdf = w.urdf()
    for leaf in singles + pair:  # every optical frame's name begins "camera_"
        urdf = urdf.replace(f'"{leaf}"'.encode(), f'"camera_{leaf}"'.encode())
    singles, pair = [f"camera_{leaf}" for leaf in singles], [f"camera_{leaf}" for leaf in pair]
    tree = load_urdf(urdf)
    leaves = singles + pair
    oracle = Oracle(ScriptedBackend(lambda q: "camera" if "camera" in q.options else q.options[0]))
    groups = merge(oracle, tree, [sub_chain(tree, leaf, base) for leaf in leaves], "sensor",
                   dict.fromkeys(leaves, "VisionSensor"))
    assert sorted(sorted(g.leaves) for g in groups) == sorted([[s] for s in singles] + [sorted(pair)])


@pytest.mark.parametrize("mesh", ["d405", None])
def test_a_depth_cameras_frames_on_a_hand_split_by_the_model_are_one_kind_where_its_housing_names_it(mesh):
    """A parallel gripper's palm carries, bolted below a bracket, a depth camera's housing with four imagers (each a
    body frame and an optical frame below it). The model calls one optical frame part of an end-effector (0.52) and
    the others sensors (0.6). Where the housing is drawn with a catalogue product's mesh (`d405`, a depth camera), the
    four are one device's frames and take the product's kind; a plain box names nothing, and a hand's palm carries
    its tool frames beside its sensors' frames, so the votes stand (on the code before: the named housing too, and
    the camera came apart, one imager in the gripper)."""
    w = Writer(random.Random(11))
    base = w.link('<box size="0.3 0.3 0.1"/>', centre=(0.0, 0.0, 0.0), mass=5.0)
    palm = w.link('<box size="0.08 0.1 0.04"/>', centre=(0.0, 0.0, 0.0), mass=0.4)
    w.joint("revolute", w.arm(base), palm, (0.0, 0.0, 0.1), (0.0, 0.0, 1.0), (-3.0, 3.0))
    tips = []
    for side in (1.0, -1.0):
        finger = w.link('<box size="0.01 0.02 0.06"/>', centre=(0.0, 0.0, 0.03), mass=0.05)
        w.joint("prismatic", palm, finger, (0.0, side * 0.02, 0.04), (0.0, side, 0.0), (0.0, 0.04))
        tips.append(tip := w.link())
        w.joint("fixed", finger, tip, (0.0, 0.0, 0.06))
    bracket = w.link()
    w.joint("fixed", palm, bracket, (0.03, 0.0, 0.02), rpy=(0.0, -1.4, 0.0))
    shape = f'<mesh filename="package://gripper_description/meshes/{mesh}.stl"/>' if mesh else '<box size="0.02 0.04 0.04"/>'
    housing = w.link(shape, centre=(0.0, 0.0, 0.0), mass=0.07)
    w.joint("fixed", bracket, housing, (0.01, 0.0, 0.02))
    frames = []
    for y in (0.0, 0.0, -0.018, 0.0):
        own, optical = w.link(), w.link()
        w.joint("fixed", housing, own, (0.0, y, 0.0))
        w.joint("fixed", own, optical, rpy=OPTICAL)
        frames.append(optical)
    tree = load_urdf(w.urdf())
    sensor, tool = TAX.answer(TAX.kinds["sensor"].cls), TAX.answer(TAX.kinds["end_effector"].cls)

    def rule(q):
        leaf = q.key.split(":", 1)[1]
        if leaf in tips or leaf == frames[2]:
            return {tool: 0.52, sensor: 0.48}
        return {sensor: 0.6, tool: 0.4}
    context, state = Abstractor(Oracle(ScriptedBackend(rule)), TAX).context(tree, kind="sensor"), Findings()
    for step in SENSOR_PASS.steps[:2]:
        step(context, state)
    assert housing in state.palms and tips[0] in state.hand_mounts
    kinds = {f: state.claims[f] for f in frames}
    cls = TAX.kinds["sensor"].cls
    if mesh:
        assert kinds == dict.fromkeys(frames, cls)
    else:
        assert kinds[frames[2]] == TAX.kinds["end_effector"].cls and kinds[frames[0]] == cls


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("beside", ["t265", "d435"])
def test_frames_naming_products_of_two_kinds_are_two_devices_whatever_the_names_share(seed, beside):
    """A sensor head carries a depth camera (a bare body frame and its optical frame, named for a RealSense D435) and,
    a few centimetres away, a bare pose frame named for a RealSense T265 (a tracking camera) or for the D435 again;
    the model names both one device (their names share a stem). Frames naming products of two kinds are two devices;
    one product's frames stay one (on the code before: the tracking camera's frame was part of the RGB-D camera)."""
    w = Writer(random.Random(seed))
    base, head = w.link('<box size="0.6 0.3 0.1"/>'), w.link()
    w.joint("fixed", base, head, (0.4, 0.0, 0.0))
    stem = w.name()
    body, optical, pose = f"{stem}_d435_link", f"{stem}_d435_optical_frame", f"{stem}_{beside}_pose_frame"
    w.links += [f'<link name="{name}"/>' for name in (body, optical, pose)]
    w.joint("fixed", head, body, (0.03, 0.0, 0.045))
    w.joint("fixed", body, optical, rpy=OPTICAL)
    w.joint("fixed", head, pose, (0.03, 0.01, 0.02))
    tree = load_urdf(w.urdf())
    frames = [optical, pose]
    groups = merge(Oracle(ScriptedBackend(lambda q: q.options[0])), tree, [sub_chain(tree, f, base) for f in frames],
                   "sensor", dict.fromkeys(frames, "VisionSensor"))
    expected = [[optical], [pose]] if beside == "t265" else [sorted(frames)]
    assert sorted(sorted(g.leaves) for g in groups) == expected


@pytest.mark.parametrize("seed", range(10))
@pytest.mark.parametrize("declared", [True, False])
def test_a_lidars_cap_is_its_own_whatever_sensor_the_model_took_it_for(seed, declared):
    """A lidar drawn as a cylinder on a base carries its scan frame and a cap fixed straight to it. The model reads
    the cap as an inertial sensor (an Ouster's cap, asked alone): where the file declares the lidar on its scan frame,
    the cap is the housing's own piece, one device with the frame. Where nothing is declared on the frame, nothing says
    what the frame is, and the model's two kinds stay two devices."""
    w = Writer(random.Random(seed))
    base = w.link('<box size="0.5 0.4 0.2"/>')
    plate = w.link('<box size="0.11 0.11 0.02"/>')
    w.joint("fixed", base, plate, (0.1, 0.0, 0.15))
    housing = w.link('<cylinder radius="0.0435" length="0.058"/>', mass=0.41)
    w.joint("fixed", plate, housing, (0.0, 0.0, 0.02))
    cap, frame = w.link('<cylinder radius="0.0434" length="0.022"/>', mass=0.09), w.link()
    w.joint("fixed", housing, cap, (0.0, 0.0, 0.058))
    w.joint("fixed", housing, frame, (0.0, 0.0, 0.038))
    text = (f'<gazebo reference="{frame}"><sensor name="lidar" type="gpu_ray"><update_rate>10</update_rate>'
            '</sensor></gazebo>') if declared else ""
    tree = load_urdf(w.urdf().replace(b"</robot>", text.encode() + b"</robot>"))
    chains = [sub_chain(tree, cap, base), sub_chain(tree, frame, base)]
    oracle = Oracle(ScriptedBackend(lambda q: q.options[-1]))  # the whole name: a device of its own
    groups = merge(oracle, tree, chains, "sensor", {cap: "InertialSensor", frame: "RangingSensor"})
    expected = [[cap, frame]] if declared else [[cap], [frame]]
    assert sorted(sorted(g.leaves) for g in groups) == sorted(sorted(e) for e in expected)
