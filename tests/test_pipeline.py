"""The abstraction stages and passes, driven by a scripted model and the scripted reasoner on an invented robot."""
from __future__ import annotations

import io
import json
import math
import random

import pytest

from tests.scripted_reasoner import scripted_reasoner
from tests.toy_robot import TAX, TOY, perfect
from tests.urdf_writer import Writer
from urdfkb.pipeline.abstraction.abstractor import Abstractor
from urdfkb.pipeline.errors import BackendError
from urdfkb.pipeline.reading.ingest import load_urdf
from urdfkb.pipeline.llm.base import Question
from urdfkb.pipeline.llm.scripted import ScriptedBackend
from urdfkb.pipeline.abstraction.oracle import Oracle
from urdfkb.pipeline.abstraction.prompts import NONE
from urdfkb.pipeline.abstraction.stages.attachment import SubChain, mount_candidates
from urdfkb.pipeline.abstraction.stages.identification import identify
from urdfkb.pipeline.abstraction.stages.classification import Subject, descend
from urdfkb.pipeline.abstraction.stages import grouping
from urdfkb.pipeline.abstraction.stages.grouping import Group, device_names, merge, name_prefixes
from urdfkb.pipeline.abstraction.stages.verification import verify


@pytest.fixture
def toy():
    return load_urdf(TOY)


def abstract(tree, rule=perfect, vote=None):
    return Abstractor(Oracle(ScriptedBackend(rule), vote=vote), TAX, reasoner=scripted_reasoner).run(tree).components


def test_toy_robot_is_abstracted_into_its_devices(toy):
    comps = {c.cls: c for c in abstract(toy)}
    assert set(comps) == {"Lidar", "RGBDCamera", "ParallelGripper"}
    assert comps["Lidar"].root == "chassis" and comps["Lidar"].links == ("front_scanner",)
    camera = comps["RGBDCamera"]
    assert camera.root == "mast" and camera.kind == "sensor"
    assert {s.link: s.cls for s in camera.subcomponents} == {
        "mast_rgbd_body": "SensorHousing", "mast_rgbd_color_optical": "RgbFrame", "mast_rgbd_depth_optical": "DepthFrame"}
    gripper = comps["ParallelGripper"]
    assert gripper.kind == "end_effector" and gripper.root == "arm_flange"
    # the status light was identified as no component, so verification absorbed it into the gripper
    assert {s.link: s.cls for s in gripper.subcomponents}["claw_status_light"] == "StructuralSubpart"
    assert set(gripper.links) == {"claw_base", "claw_jaw_a", "claw_jaw_b", "claw_tcp", "claw_status_light"}


def test_every_link_belongs_to_at_most_one_component(toy):
    links = [link for c in abstract(toy) for link in c.links]
    assert len(links) == len(set(links))


def test_confidence_is_the_product_along_the_descent(toy):
    def unsure(q):
        if q.key == "pre:front_scanner@Sensor":
            return {"ranging sensor": 0.6, "vision sensor": 0.4}
        if q.key == "pre:front_scanner@RangingSensor":
            return {"lidar": 0.8, "sonar": 0.2}
        return perfect(q)
    lidar = next(c for c in abstract(toy, unsure) if c.root == "chassis")
    assert lidar.cls == "Lidar" and lidar.confidence == pytest.approx(0.48, abs=1e-3)


@pytest.mark.parametrize("answer", ["mechanism", "passive part"])
def test_a_leaf_the_sensor_check_calls_a_drive_part_or_a_passive_part_is_no_sensor(toy, answer):
    def screw_scanner(q):
        return answer if q.key == "check:front_scanner" else perfect(q)
    assert "Lidar" not in {c.cls for c in abstract(toy, screw_scanner)}
    # the other answers of the check are traced but overrule nothing
    for other in ("emitter", "reference frame"):
        kept = abstract(toy, lambda q: other if q.key == "check:front_scanner" else perfect(q))
        assert "Lidar" in {c.cls for c in kept}


def test_a_leaf_both_questions_call_a_sensor_only_by_a_clear_minority_is_no_sensor(toy):
    def unsure(identified: float, checked: float):
        def answer(q):
            if q.key == "identify:front_scanner":
                return {"sensor": identified, "end effector": (1 - identified) / 2, "none": (1 - identified) / 2}
            if q.key == "check:front_scanner":
                return {"sensor": checked, "emitter": (1 - checked) / 2, "reference frame": (1 - checked) / 2}
            return perfect(q)
        return answer
    assert "Lidar" not in {c.cls for c in abstract(toy, unsure(0.35, 0.4))}
    # a near tie on both keeps it: layout noise alone could carry it over half
    assert "Lidar" in {c.cls for c in abstract(toy, unsure(0.45, 0.48))}
    # a majority in either question keeps it
    assert "Lidar" in {c.cls for c in abstract(toy, unsure(0.4, 0.6))}
    assert "Lidar" in {c.cls for c in abstract(toy, unsure(0.6, 0.4))}


def test_sampled_voting_reaches_the_same_devices(toy):
    assert {c.cls for c in abstract(toy, vote="sample")} == {"Lidar", "RGBDCamera", "ParallelGripper"}


def _asking(toy) -> tuple[list, list[str]]:
    """The toy's components under the perfect model, and the keys of the questions asked."""
    asked = []

    def spy(q):
        asked.append(q.key)
        return perfect(q)
    return abstract(toy, spy), asked


def test_each_camera_chain_leaf_is_an_optical_frame_and_the_rest_is_housing(toy):
    components, asked = _asking(toy)
    camera = next(c for c in components if c.cls == "RGBDCamera")
    parts = {s.link: s.cls for s in camera.subcomponents}
    assert parts["mast_rgbd_color_optical"] == "RgbFrame" and parts["mast_rgbd_depth_optical"] == "DepthFrame"
    assert "part:mast_rgbd_color_optical@OpticalFrame" in asked  # the leaf is typed below OpticalFrame
    # the body is not an optical frame and a camera has no sensing element: housing is the only
    # class left, so it is typed without a question
    assert not any(k.startswith("part:mast_rgbd_body") for k in asked)
    assert parts["mast_rgbd_body"] == "SensorHousing"


def test_a_non_vision_sensor_measures_at_its_chain_leaf_with_no_question(toy):
    components, asked = _asking(toy)
    lidar = next(c for c in components if c.cls == "Lidar")
    # the shapes require a sensing element of a ranging sensor: its chain's leaf, and SensingElement has no kinds
    assert {s.link: s.cls for s in lidar.subcomponents} == {"front_scanner": "SensingElement"}
    assert not any(k.startswith("part:front_scanner") for k in asked)


def test_end_effector_chains_meeting_inside_a_mount_are_one_tool(toy):
    def tcp_high(q):
        if q.key == "root:claw_tcp":
            return "arm_fore"  # higher than the jaws' mount: the chains still meet at claw_base
        return perfect(q)
    (gripper,) = [c for c in abstract(toy, tcp_high) if c.kind == "end_effector"]
    assert gripper.root == "arm_flange"  # the deepest named mount that carries every chain
    assert set(gripper.links) == {"claw_base", "claw_jaw_a", "claw_jaw_b", "claw_tcp", "claw_status_light"}


@pytest.mark.parametrize("failure", [RuntimeError("model crashed"), TimeoutError("no answer")])
def test_backend_failure_is_a_clear_error(toy, failure):
    def broken(q):
        raise failure
    with pytest.raises(BackendError, match="scripted"):
        abstract(toy, broken)


def test_answers_outside_the_options_are_abstentions_not_classes(toy):
    def wild(q):
        if q.key.startswith("pre:"):
            return "GalacticSensor"
        return q.options[0] if q.key.startswith("part:front_scanner") else perfect(q)  # a bare Sensor's parts
    comps = abstract(toy, wild, vote="sample")
    assert comps and all(c.cls in TAX for c in comps)


def test_identification_offers_the_component_kinds_and_none(toy):
    seen = {}

    def spy(q):
        seen[q.key] = q.options
        return perfect(q)
    Abstractor(Oracle(ScriptedBackend(spy)), TAX, reasoner=scripted_reasoner).run(toy)
    assert seen["identify:front_scanner"] == ("sensor", "end effector", "body part", NONE)


def test_mount_candidates_stop_at_the_first_link_carrying_another_kind(toy):
    blocked = lambda link: link.startswith("drive_wheel")  # noqa: E731 - wheels are body parts
    assert mount_candidates(toy, "mast_rgbd_color_optical", blocked) == ["mast_rgbd_body", "mast", "chassis"]
    assert mount_candidates(toy, "front_scanner", blocked) == ["chassis"]


def test_sensor_mount_candidates_end_at_the_first_joint_that_moves(toy):
    never = lambda link: False  # noqa: E731
    assert mount_candidates(toy, "claw_tcp", never) == ["claw_base", "arm_flange", "arm_fore", "arm_upper", "arm_base", "chassis"]
    assert mount_candidates(toy, "claw_tcp", never, rigid=True) == ["claw_base", "arm_flange"]
    assert mount_candidates(toy, "drive_wheel_left", never, rigid=True) == ["chassis"]
    assert mount_candidates(toy, "mast_rgbd_color_optical", never, rigid=True) == ["mast_rgbd_body", "mast", "chassis"]


def test_descend_passes_through_lone_subclasses_without_asking():
    asked = []

    def rule(q):
        asked.append(q.key)
        return "vision sensor" if q.key.endswith("@Sensor") else "stereo camera"
    (typed,) = descend(Oracle(ScriptedBackend(rule)), TAX, "Sensor", [Subject("pre:x", "The link below belongs to a {concept}.", "Link: x")], "pre")
    assert typed.cls == "StereoCamera"
    assert asked == ["pre:x@Sensor", "pre:x@Camera"]  # VisionSensor has one subclass: not asked


def test_a_ranging_sensor_that_is_neither_lidar_nor_sonar_stays_a_ranging_sensor():
    """The ontology's core:otherAnswer on RangingSensor is offered beside its kinds (a cliff or wall sensor
    measures one beam), also where a declaration leaves one kind: the lone kind is then asked, not passed through."""
    seen = {}

    def rule(q):
        seen[q.key] = q.options
        return "ranging sensor" if q.key.endswith("@Sensor") else "other ranging sensor"
    subject = Subject("pre:x", "The link below belongs to a {concept}.", "Link: cliff_front_link")
    (typed,) = descend(Oracle(ScriptedBackend(rule)), TAX, "Sensor", [subject], "pre")
    assert typed.cls == "RangingSensor"
    assert seen["pre:x@RangingSensor"] == ("lidar", "sonar", "other ranging sensor")
    narrowed = Subject("pre:y", subject.framing, subject.evidence, frozenset({"Sonar"}))
    (typed,) = descend(Oracle(ScriptedBackend(rule)), TAX, "Sensor", [narrowed], "pre")
    assert typed.cls == "RangingSensor" and seen["pre:y@RangingSensor"] == ("lidar", "other ranging sensor")


def test_name_prefixes_break_at_underscores_namespaces_and_case_changes():
    assert name_prefixes("SurroundingFrontLaser_device_frame") == (
        "Surrounding", "SurroundingFront", "SurroundingFrontLaser", "SurroundingFrontLaser_device",
        "SurroundingFrontLaser_device_frame")
    assert name_prefixes("imu") == ("imu",)
    assert name_prefixes("multisense/top_left") == ("multisense", "multisense/top", "multisense/top_left")


def test_device_names_leave_out_the_body_part_the_device_is_mounted_on():
    chain = SubChain("Mast_scanner_optical_frame", "Mast_link", ("Mast_scanner_optical_frame",))
    assert device_names(chain) == ("Mast_scanner", "Mast_scanner_optical", "Mast_scanner_optical_frame")
    flat = SubChain("Crown", "Crown", ("Crown",))  # never left without an answer
    assert device_names(flat) == ("Crown",)


def test_merge_is_a_partition_joining_near_chains_with_one_device_name_and_category(toy, monkeypatch):
    monkeypatch.setattr(grouping, "_one_body", lambda *args: False)  # names alone: these leaves are no links of a tree
    monkeypatch.setattr(grouping, "_bare_cameras_apart", lambda *args: False)  # nor do they look anywhere
    monkeypatch.setattr(grouping, "_aliases", lambda *args: set())  # nor lie anywhere
    monkeypatch.setattr(grouping, "_bare_apart", lambda *args: False)
    monkeypatch.setattr(grouping, "optical_twins", lambda *args: False)
    monkeypatch.setattr(grouping, "named_product", lambda *args: None)  # nor name a product
    chains = [SubChain("cam_a_rgb", "mount", ("cam_a_rgb",)), SubChain("cam_a_depth", "mount", ("cam_a_depth",)),
              SubChain("cam_b_rgb", "mount", ("cam_b_rgb",)), SubChain("cam_a_far", "elsewhere", ("cam_a_far",)),
              SubChain("cam_a_led", "mount", ("cam_a_led",))]
    names = {"cam_a_rgb": "cam_a", "cam_a_depth": "cam_a", "cam_b_rgb": "cam_b", "cam_a_far": "cam_a", "cam_a_led": "cam_a"}
    categories = dict.fromkeys(names, "VisionSensor") | {"cam_a_led": "ContactSensor"}
    asked: list[str] = []

    def rule(question: Question) -> str:
        asked.append(question.key)
        return names[question.key.split(":")[1]]
    backend = ScriptedBackend(rule)
    groups = merge(Oracle(backend), toy, chains, "sensor", categories)
    assert sorted(sorted(g.leaves) for g in groups) == [["cam_a_depth", "cam_a_rgb"], ["cam_a_far"], ["cam_a_led"], ["cam_b_rgb"]]
    # the far camera and the LED (alone in their category at their mount) are devices whatever their names
    assert sorted(asked) == ["device:cam_a_depth", "device:cam_a_rgb", "device:cam_b_rgb"]


def test_end_effector_chains_merge_where_their_leaves_meet_inside_a_mount(toy):
    jaw = SubChain("claw_jaw_a", "arm_flange", ("claw_base", "claw_jaw_a"))
    tcp = SubChain("claw_tcp", "claw_base", ("claw_tcp",))
    scanner = SubChain("front_scanner", "chassis", ("front_scanner",))
    groups = merge(Oracle(ScriptedBackend(perfect)), toy, [jaw, tcp, scanner], "end_effector", {})
    assert sorted(sorted(g.leaves) for g in groups) == [["claw_jaw_a", "claw_tcp"], ["front_scanner"]]


def test_verification_reroots_a_device_that_carries_other_things(toy):
    # mounted too high: the chassis-level chain would swallow the mast, which carries the camera
    chain = SubChain("front_scanner", "chassis", ("front_scanner",))
    too_high = SubChain("mast_rgbd_color_optical", "chassis", ("mast", "mast_rgbd_body", "mast_rgbd_color_optical"))
    notes: list[str] = []
    groups = verify(toy, [Group([too_high]), Group([chain])], lambda link: False, notes.append)
    camera = next(g for g in groups if g.leaves == ["mast_rgbd_color_optical"])
    assert camera.members == ["mast_rgbd_color_optical"] and any("re-root" in n for n in notes)


def test_verification_absorbs_unclaimed_links(toy):
    chain = SubChain("claw_tcp", "arm_flange", ("claw_base", "claw_tcp"))
    notes: list[str] = []
    (group,) = verify(toy, [Group([chain])], lambda link: True, notes.append)
    assert set(group.members) == {"claw_base", "claw_tcp", "claw_jaw_a", "claw_jaw_b", "claw_status_light"}
    assert notes and notes[0].startswith("absorb")


def test_trace_records_every_question(toy):
    out = io.StringIO()
    Abstractor(Oracle(ScriptedBackend(perfect), trace=out), TAX, reasoner=scripted_reasoner).run(toy)
    records = [json.loads(line) for line in out.getvalue().splitlines()]
    questions = [r for r in records if "options" in r]
    # no "device": the toy's colour and depth frames hang from one camera body, one device by structure; no
    # "post": a colour and a depth frame leave the RGB-D camera the only class the definitions allow
    assert {r["key"].split(":")[0] for r in questions} >= {"identify", "root", "pre", "part"}
    assert all(r["answer"] in r["options"] for r in questions)
    (reasoner,) = [r for r in records if r["key"] == "reasoner"]  # the gripper's kind came from its structure
    assert reasoner["tools"][0]["inferred"] == "ParallelGripper"


def test_post_classification_starts_from_what_the_members_share_and_the_frames_decide(toy):
    """Colour (monocular) and depth frames share Camera: the group's frames are typed first, below the optical
    frame, and a colour and a depth frame leave only the RGB-D camera below Camera: nothing is asked of it."""
    asked = []

    def spy(q):
        asked.append(q.key)
        return "monocular camera" if q.key.startswith("post:") else perfect(q)  # would name it wrongly
    comps = {c.cls: c for c in abstract(toy, spy)}
    assert {"part:mast_rgbd_color_optical@OpticalFrame", "part:mast_rgbd_depth_optical@OpticalFrame"} <= set(asked)
    assert not [k for k in asked if k.startswith("post:mast")]
    assert {s.link: s.cls for s in comps["RGBDCamera"].subcomponents if s.link.endswith("optical")} == {
        "mast_rgbd_color_optical": "RgbFrame", "mast_rgbd_depth_optical": "DepthFrame"}


def test_several_touch_pads_read_as_one_device_are_an_array():
    """Three touch frames on a head named as one device: a tactile sensor is one pad (core:elementCount), so the
    device is not offered "touch sensor", though the model calls each frame one."""
    pads = ["headtouch_front_frame", "headtouch_middle_frame", "headtouch_rear_frame"]
    urdf = ('<robot name="toucher"><link name="base"><visual><geometry><box size="0.3 0.3 0.3"/></geometry></visual>'
            '</link><link name="head"><visual><geometry><sphere radius="0.1"/></geometry></visual></link>'
            '<joint name="neck" type="revolute"><parent link="base"/><child link="head"/><axis xyz="0 0 1"/>'
            '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint>'
            + "".join(f'<link name="{p}"/><joint name="{p}_joint" type="fixed"><parent link="head"/><child link="{p}"/>'
                      f'<origin xyz="{0.05 * (1 - i)} 0 0.1"/></joint>' for i, p in enumerate(pads)) + '</robot>')
    offered = {}

    def reads_pads(q):
        stage, _, subject = q.key.partition(":")
        offered[q.key] = q.options
        if stage == "identify":
            return "sensor" if subject in pads else q.options[-1]
        if stage in ("check",):
            return "sensor"
        if stage == "device":
            return "headtouch"
        if q.key.startswith("post:") and "touch sensor array" in q.options:
            return "touch sensor array"
        if stage in ("pre", "post"):
            return next(o for o in ("contact sensor", "touch sensor") if o in q.options)
        return q.options[0]
    comps = Abstractor(Oracle(ScriptedBackend(reads_pads)), TAX, reasoner=scripted_reasoner).run(load_urdf(urdf.encode())).components
    touch = [c for c in comps if c.kind == "sensor"]
    assert [(c.cls, sorted(s.link for s in c.subcomponents if s.link in pads)) for c in touch] == [("TactileArray", pads)]
    assert all("touch sensor" not in options for key, options in offered.items() if key.startswith("post:"))


@pytest.mark.parametrize("name", ["claw_led_frame", "claw_speaker", "claw_display"])
def test_a_leaf_naming_an_emitter_is_no_sensor_whatever_the_model_reads(tmp_path, name):
    """A status LED (a loudspeaker, a display) gives out and measures nothing: the catalogue's emitter kinds
    settle it as part of no component, unasked, so the model's reading it as a button cannot split it from
    the gripper it sits on; verification absorbs it into that gripper."""
    urdf = tmp_path / "toy.urdf"
    urdf.write_text(TOY.read_text().replace("claw_status_light", name))

    def button(q):
        key = q.key.replace(name, "claw_status_light")
        if key == "identify:claw_status_light":
            return "sensor"
        if key.startswith("pre:claw_status_light@"):
            return next(o for o in q.options if o in ("contact sensor", "button"))
        return perfect(Question(q.system, q.user, q.options, key=key))
    comps = abstract(load_urdf(urdf), button)
    assert {c.cls for c in comps} == {"Lidar", "RGBDCamera", "ParallelGripper"}
    gripper = next(c for c in comps if c.cls == "ParallelGripper")
    assert name in gripper.links


def test_a_leaf_on_a_joint_others_follow_drives_them_and_is_no_sensor(tmp_path):
    """The status light becomes a horn turned by a continuous joint both jaws mimic (a servo horn that drives a
    gripper's fingers): the scripted model reads it as a force-torque sensor at every question, yet it is no
    sensor, and the gripper keeps it."""
    text = TOY.read_text().replace("claw_status_light", "claw_horn")
    text = text.replace('<joint name="g4" type="fixed">', '<joint name="g4" type="continuous">')
    text = text.replace('<axis xyz="0 -1 0"/>', '<axis xyz="0 -1 0"/>\n    <mimic joint="g4"/>')
    text = text.replace('<mimic joint="g1"/>', '<mimic joint="g4"/>')
    urdf = tmp_path / "toy.urdf"
    urdf.write_text(text)

    def torque(q):
        if q.key in ("identify:claw_horn", "check:claw_horn"):
            return "sensor"
        if q.key.startswith("pre:claw_horn@") or q.key.startswith("post:claw_horn@"):
            return "force-torque sensor" if "force-torque sensor" in q.options else q.options[0]
        return perfect(Question(q.system, q.user, q.options, key=q.key.replace("claw_horn", "claw_status_light")))
    comps = abstract(load_urdf(urdf), torque)
    assert not [c for c in comps if c.kind == "sensor" and "claw_horn" in c.links]
    assert "claw_horn" in next(c for c in comps if c.kind == "end_effector").links


@pytest.mark.parametrize("seed", range(3))
def test_the_link_a_sensor_is_declared_on_is_its_body_not_its_mount(seed):
    """The model mounted a quadruped's face camera on the camera's own housing (the link its depth sensor is declared
    on, carrying only the optical frame): a fixed link that declares a sensor and carries nothing but the sensor's
    chain is the sensor's body, never offered as its mount; a trunk declaring an IMU still carries other things, and a
    lidar's spinning head keeps its body as the one candidate it had."""
    w = Writer(random.Random(seed))
    footprint, trunk = w.link(), w.link('<box size="0.4 0.2 0.1"/>')
    housing, optical, leg = w.link('<box size="0.001 0.001 0.001"/>'), w.link(), w.link('<box size="0.05 0.05 0.2"/>')
    imu, lidar, rotor = w.link(), w.link('<cylinder radius="0.04" length="0.05"/>'), w.link()
    w.joint("fixed", footprint, trunk, xyz=(0.0, 0.0, 0.3))
    w.joint("fixed", trunk, lidar, xyz=(0.0, 0.0, 0.08))
    w.joint("continuous", lidar, rotor, xyz=(0.0, 0.0, 0.02))
    w.joint("fixed", trunk, housing, xyz=(0.28, 0.0, 0.0))
    w.joint("fixed", housing, optical, rpy=(-math.pi / 2, 0.0, -math.pi / 2))
    w.joint("revolute", trunk, leg, xyz=(0.2, 0.1, 0.0), axis=(0.0, 1.0, 0.0))
    w.joint("fixed", trunk, imu)
    gazebo = (f'<gazebo reference="{housing}"><sensor name="c" type="depth"><plugin name="p" filename="libcam.so">'
              f'<frameName>{optical}</frameName></plugin></sensor></gazebo>'
              f'<gazebo reference="{trunk}"><sensor name="i" type="imu"/></gazebo>'
              f'<gazebo reference="{lidar}"><sensor name="l" type="gpu_ray"/></gazebo>')
    tree = load_urdf(w.urdf().replace(b"</robot>", gazebo.encode() + b"</robot>"))
    never = lambda link: False  # noqa: E731
    assert mount_candidates(tree, optical, never, rigid=True) == [trunk, footprint]
    assert mount_candidates(tree, optical, never) == [housing, trunk, footprint]  # a tool's links are no sensor's body
    assert mount_candidates(tree, imu, never, rigid=True) == [trunk, footprint]  # a trunk carries other things
    assert mount_candidates(tree, rotor, never, rigid=True) == [lidar]  # a leaf spinning on its body keeps it


@pytest.mark.parametrize("seed", range(3))
def test_a_housing_named_for_a_stereo_product_is_half_the_device_not_its_mount(seed):
    """A car's stereo camera written as two housings, each drawn with a camera frame in front declaring one camera.
    A fixed link whose own name names a catalogue product that sees from two places (the ZED, a stereo camera) and
    carries nothing but one camera's chain is half that device, never offered as its mount, so both cameras share
    the chassis as their one candidate; a lidar's base named for its product (the Velodyne, which sees from one
    place) stays offered, as the truth files take it."""
    w = Writer(random.Random(seed))
    chassis = w.link('<box size="0.4 0.2 0.1"/>')
    cameras = []
    for side in ("left", "right"):
        housing = f"zed_{side}_housing_{seed}"
        w.links.append(f'<link name="{housing}"><visual><geometry><box size="0.03 0.03 0.03"/></geometry></visual></link>')
        camera = w.link('<box size="0.02 0.02 0.02"/>')
        w.joint("fixed", chassis, housing, xyz=(0.1, 0.03 if side == "left" else -0.03, 0.08))
        w.joint("fixed", housing, camera, xyz=(0.04, 0.0, 0.04))
        cameras.append(camera)
    tower, lidar = f"velodyne_base_{seed}", w.link('<cylinder radius="0.04" length="0.05"/>')
    w.links.append(f'<link name="{tower}"><visual><geometry><box size="0.05 0.05 0.1"/></geometry></visual></link>')
    w.joint("fixed", chassis, tower, xyz=(-0.1, 0.0, 0.1))
    w.joint("fixed", tower, lidar, xyz=(0.0, 0.0, 0.09))
    gazebo = "".join(f'<gazebo reference="{c}"><sensor name="s{k}" type="camera"/></gazebo>' for k, c in enumerate(cameras))
    gazebo += f'<gazebo reference="{lidar}"><sensor name="l" type="ray"/></gazebo>'
    tree = load_urdf(w.urdf().replace(b"</robot>", gazebo.encode() + b"</robot>"))
    never = lambda link: False  # noqa: E731
    assert [mount_candidates(tree, c, never, rigid=True) for c in cameras] == [[chassis], [chassis]]
    assert mount_candidates(tree, lidar, never, rigid=True) == [tower, chassis]


@pytest.mark.parametrize("seed", range(5))
def test_a_bare_frame_where_a_display_is_drawn_is_its_frame_not_a_sensor(seed):
    """A face carries two display screens (drawn, named by their meshes) and, at each screen's place, a bare frame
    (`eye_left` on a robot whose eyes are screens). The model reads every leaf as a sensor: the screens are settled
    as no component by the catalogue, and each frame where a screen is with them, unasked; a bare frame elsewhere on
    the face (a camera's) is still asked."""
    w = Writer(random.Random(seed))
    base, head = w.link('<box size="0.3 0.2 0.2"/>'), w.link('<box size="0.1 0.12 0.1"/>')
    w.joint("revolute", base, head, (0.0, 0.0, 0.4))
    frames, screens = [], []
    for y in (0.034, -0.034):
        screen, frame = w.link('<mesh filename="package://face/meshes/screen.stl"/>'), w.link()
        w.joint("fixed", head, screen, (0.07, y, 0.006))
        w.joint("fixed", head, frame, (0.07, y, 0.006))
        screens.append(screen)
        frames.append(frame)
    camera = w.link()
    w.joint("fixed", head, camera, (0.095, 0.0, 0.055))
    tree = load_urdf(w.urdf())
    asked = []

    def sensor(q):
        asked.append(q.key)
        return "sensor"
    answers = identify(Oracle(ScriptedBackend(sensor)), TAX, tree, [*screens, *frames, camera])
    assert all(answers[link] == (NONE, 1.0) for link in [*screens, *frames])
    assert answers[camera][0] != NONE
    assert not [key for key in asked if any(key.endswith(link) for link in [*screens, *frames])]
