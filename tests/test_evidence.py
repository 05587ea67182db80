"""Evidence read from the whole URDF, and how it reaches the model and narrows its options."""
from __future__ import annotations

import dataclasses
import json
import math
import random
import re
from pathlib import Path

import pytest

from urdfkb.pipeline.abstraction.abstractor import Abstractor
from urdfkb.pipeline.reading.evidence import LinkEvidence, SimSensor, mesh_stem, named
from urdfkb.pipeline.reading.ingest import load_urdf
from urdfkb.pipeline.llm.base import Question
from urdfkb.pipeline.llm.scripted import ScriptedBackend
from urdfkb.pipeline.knowledge.ontology import vocabulary
from urdfkb.pipeline.abstraction.oracle import Oracle
from urdfkb.pipeline.abstraction.prompts import NONE
from urdfkb.pipeline.runner import Settings, run
from tests.urdf_writer import Writer
from urdfkb.pipeline.abstraction.stages.attachment import sub_chain
from urdfkb.pipeline.abstraction.stages.classification import Typed
from urdfkb.pipeline.abstraction.stages.grouping import Group
from urdfkb.pipeline.abstraction.steps.classify import numbered_units
from urdfkb.pipeline.abstraction.steps.findings import Findings

BOT = Path(__file__).parent / "data" / "sensor_bot.urdf"
TAX = vocabulary()


@pytest.fixture(scope="module")
def bot():
    return load_urdf(BOT)


@pytest.mark.parametrize("filename, stem", [
    ("package://turtle_description/meshes/sensors/lds.stl", "sensors/lds"),
    ("package://arm_description/meshes/gripper_v0/l_finger_tip.dae", "gripper_v0/l_finger_tip"),
    ("package://cam_description/models/eye.dae", "models/eye"),
    ("file:///opt/robot/meshes/hand.STL", "hand"),
    ("meshes/a/b/c/wrist.obj", "c/wrist"),
    ("", ""),
])
def test_mesh_stems_keep_the_informative_end_of_the_path(filename, stem):
    assert mesh_stem(filename) == stem


def test_meshes_shapes_and_mass_are_read_per_link(bot):
    hull, nose, eye = bot.evidence["hull"], bot.evidence["nose_scanner"], bot.evidence["mast_eye_body"]
    assert hull.meshes == ("body/hull_v2",) and hull.shape == "box 0.6x0.4x0.2 m" and hull.mass == 12.0
    assert nose.meshes == ("sensors/spinner_x9",) and nose.mass is None
    assert eye.shape == "cylinder r=0.03 l=0.05 m"
    assert bot.evidence["mast_eye_optical"].is_pure_frame
    assert bot.evidence["mast_eye_optical"].text().startswith("no geometry, massless")


def test_a_link_is_named_with_its_facts_in_parentheses_and_bare_without(bot):
    assert named(bot.evidence, "hull") == "hull (mesh body/hull_v2; box 0.6x0.4x0.2 m)"
    assert named(bot.evidence, "mast_eye_optical") == "mast_eye_optical (no geometry, massless)"
    assert named({}, "hull") == "hull"


def test_sdf_sensor_declarations_with_plugin_and_numbers(bot):
    assert bot.evidence["nose_scanner"].sensors == (
        SimSensor("gpu_ray", ("gazebo_ros_gpu_laser",), "nose_scanner", samples=720, fov=3.1416, min_range=0.1,
                  max_range=30.0, name="nose"),)
    assert bot.evidence["hull"].sensors == ()  # a <gazebo> block without a sensor declares nothing
    assert bot.evidence["echo_1_link"].sensors == (SimSensor("ray", ("gazebo_ros_range",), "echo_1_link", name="echo_1"),)  # no number


def test_old_gazebo_sensor_form_is_read_as_the_same_type_with_angles_in_degrees(bot):
    [tail] = bot.evidence["tail_scanner"].sensors
    assert (tail.type, tail.plugins, tail.reference, tail.frame) == ("ray", ("gazebo_ros_laser",), "tail_scanner", "tail_scanner")
    assert (tail.samples, tail.fov, tail.max_range, tail.min_range) == (181, pytest.approx(math.pi), 8.0, None)


def test_a_declaration_also_reaches_the_frame_its_plugin_publishes_in(bot):
    camera = SimSensor("camera", ("gazebo_ros_camera",), "mast_eye_body", "mast_eye_optical", image=(1280, 720),
                       name="eye", places=((0.0, 0.0, 0.0),))
    assert bot.evidence["mast_eye_body"].sensors == (camera,)
    assert bot.evidence["mast_eye_optical"].sensors == (camera,)


def test_a_plugin_outside_sensors_gives_the_links_it_names_its_library_as_evidence():
    """A plugin names a link through an element whose tag says link, body or frame; not through a namespace, a
    topic or a joint that shares the link's name. A plugin inside a sensor, or nested in another plugin, speaks for
    itself, not for the plugin around it."""
    w = Writer(random.Random(5))
    links = [w.link('<box size="0.1 0.1 0.1"/>') for _ in range(5)]
    for parent, child in zip(links, links[1:]):
        w.joint("fixed", parent, child, (0.0, 0.0, 0.1))
    a, b, c, d, e = links
    blocks = (f'<gazebo><plugin name="p" filename="libouter_grip.so"><robotNamespace>/{b}</robotNamespace>'
              f'<bodyName>{a}</bodyName><topicName>{b}</topicName><jointName>{b}</jointName>'
              f'<sensor type="contact"><plugin filename="libinner.so"><bodyName>{c}</bodyName></plugin></sensor>'
              f'<plugin filename="libnested.so"><link_name>{d}</link_name></plugin></plugin></gazebo>'
              f'<gazebo reference="{e}"><visual><plugin filename="libcolor.so"><gripper_link>{e}</gripper_link>'
              f'</plugin></visual></gazebo>')
    tree = load_urdf(w.urdf().replace(b"</robot>", blocks.encode() + b"</robot>"))
    assert {link: tree.evidence[link].plugins for link in links} == {
        a: ("outer_grip",), b: (), c: (), d: ("nested",), e: ("color",)}


def test_the_numbers_of_both_forms_are_read_in_si_units(shared):
    pr2 = load_urdf(shared / "urdf" / "pr2.urdf").evidence
    [rgb] = pr2["head_mount_kinect_rgb_optical_frame"].sensors  # old form: hfov 57 (degrees), imageSize "640 480"
    assert (rgb.reference, rgb.rate, rgb.image, rgb.fov) == ("head_mount_kinect_rgb_link", 1.0, (640, 480),
                                                             pytest.approx(math.radians(57)))
    [laser] = pr2["base_laser_link"].sensors  # minAngle/maxAngle ±129.998° → a span in radians
    assert (laser.samples, laser.min_range, laser.max_range, laser.resolution, laser.rate) == (640, 0.08, 10.0, 0.01, 20.0)
    assert laser.fov == pytest.approx(math.radians(2 * 129.998394137))
    [xtion] = load_urdf(shared / "urdf" / "tiago.urdf").evidence["xtion_rgb_optical_frame"].sensors  # SDF, radians
    assert (xtion.type, xtion.image, xtion.fov, xtion.rate) == ("depth", (640, 480), pytest.approx(1.0995574), 30.0)


def test_a_range_plugin_states_what_its_sensor_emits_and_without_a_scan_its_cone(shared):
    """sensor_msgs/Range's radiation type, as ROS 1's gazebo_ros_range (`radiation`) and ROS 2's gazebo_ros_ray_sensor
    (`radiation_type`) state it; the plugin's `fov` is the span where the ray block states no scan, never beside one."""
    def ranger(ray: str, plugin: str) -> SimSensor:
        [sensor] = load_urdf(f'<robot name="r"><link name="a"/><gazebo reference="a"><sensor name="s" type="ray">'
                             f'<ray>{ray}<range><min>0.01</min><max>0.1</max></range></ray>'
                             f'<plugin filename="libgazebo_ros_range.so" name="p">{plugin}</plugin></sensor></gazebo>'
                             f'</robot>'.encode()).evidence["a"].sensors
        return sensor
    cone = ranger("", "<radiation>infrared</radiation><fov>0.3</fov>")
    assert (cone.fov, cone.samples, cone.radiation, cone.ranging) == (0.3, None, "infrared", True)
    scan = "<scan><horizontal><samples>5</samples><min_angle>-0.25</min_angle><max_angle>0.25</max_angle></horizontal></scan>"
    swept = ranger(scan, "<radiation_type> Ultrasound </radiation_type><fov>1.5</fov>")
    assert (swept.fov, swept.samples, swept.radiation) == (0.5, 5, "ultrasound")
    assert ranger("", "<radiation>laser</radiation>").radiation is None  # not one of the message's two
    assert ranger("", "<radiation>infrared</radiation><radiation_type>ultrasound</radiation_type>").radiation is None
    assert ranger("", "<radiation/><radiation_type> infrared</radiation_type>").radiation == "infrared"  # one stated
    [sonar, *_] = load_urdf(shared / "urdf" / "pepper.urdf").evidence["SonarFront_frame"].sensors
    assert (sonar.radiation, sonar.samples) == ("ultrasound", 5)


def test_evidence_stored_before_the_numbers_were_kept_still_loads(bot):
    old = {"meshes": [], "shape": "", "mass": None, "sensors": [{"type": "ray", "plugins": ["p"], "detail": "8 rays"}]}
    assert LinkEvidence.from_dict(old).sensors == (SimSensor("ray", ("p",)),)
    assert not LinkEvidence.from_dict(old).collision_only and LinkEvidence.from_dict(old).plugins == ()
    named = LinkEvidence(meshes=("cup",), plugins=("gazebo_ros_vacuum_gripper",))
    assert LinkEvidence.from_dict(json.loads(json.dumps(dataclasses.asdict(named)))) == named
    again = LinkEvidence.from_dict(json.loads(json.dumps(bot.to_dict()["evidence"]["mast_eye_optical"])))
    assert again == bot.evidence["mast_eye_optical"]


def test_each_declared_camera_sees_from_its_pose_after_the_sensors():
    """SDF places a camera by its own <pose> after its sensor's: a sensor turned a quarter turn about z carrying a
    camera 0.1 m along its x sees from 0.1 m along the link's y; a multicamera gives one place per camera; a sensor
    declared on a joint, or in the old form, gives none; places survive storing."""
    w = Writer(random.Random(1))
    body = w.link('<box size="0.05 0.2 0.05"/>')
    urdf = w.urdf().replace(b"</robot>", (
        f'<gazebo reference="{body}"><sensor name="a" type="camera"><pose>0.01 0 0.02 0 0 1.5707963</pose><camera>'
        '<pose>0.1 0 0 0 0 0</pose></camera></sensor>'
        '<sensor name="b" type="multicamera"><camera name="l"><pose>0 0.06 0 0 0 0</pose></camera>'
        '<camera name="r"><pose>0 -0.06 0 0 0 0</pose></camera></sensor></gazebo></robot>').encode())
    tree = load_urdf(urdf)
    one, two = tree.evidence[body].sensors
    assert [round(v, 6) for v in one.places[0]] == [0.01, 0.1, 0.02] and len(one.places) == 1
    assert two.places == ((0.0, 0.06, 0.0), (0.0, -0.06, 0.0))
    stored = LinkEvidence.from_dict(json.loads(json.dumps(dataclasses.asdict(tree.evidence[body]))))
    assert stored == tree.evidence[body]


def test_evidence_survives_condensing_and_a_change_of_evidence_misses_the_cache(bot, tmp_path, monkeypatch):
    smaller = bot.without({"echo_1_link"})
    assert "echo_1_link" not in smaller.evidence and smaller.evidence["hull"] == bot.evidence["hull"]
    monkeypatch.setenv("URDFKB_RESULT_CACHE", str(tmp_path))
    run(bot, Settings(), backend=ScriptedBackend(lambda q: q.options[0]))
    renamed_plugin = load_urdf(BOT.read_bytes().replace(b"spinner_x9", b"spinner_x8"))  # only evidence differs
    assert renamed_plugin.links == bot.links
    asked = ScriptedBackend(lambda q: q.options[0])
    run(renamed_plugin, Settings(), backend=asked)
    assert asked.stats.calls > 0


def test_the_ontology_aligns_simulator_sensor_types_to_classes():
    assert TAX.declared_classes(["ray"]) == {"RangingSensor"}
    assert TAX.declared_classes(["depth"]) == {"RGBDCamera", "DepthCamera", "RgbFrame", "DepthFrame", "InfraredFrame"}
    assert TAX.disagreeing(TAX.declared_classes(["wideanglecamera"]), "OpticalFrame") == {"DepthFrame"}
    assert TAX.disagreeing(TAX.declared_classes(["depth_camera"]), "OpticalFrame") == {"RgbFrame"}
    # a Gazebo classic depth sensor (openni, gazebo_ros_camera) publishes colour too, whatever its topics say
    assert TAX.disagreeing(TAX.declared_classes(["depth"]), "OpticalFrame") == frozenset()
    assert TAX.unformatted(["L8"], "OpticalFrame") == {"RgbFrame"} and TAX.unformatted(["R8G8B8"], "OpticalFrame") == set()
    assert TAX.declared_classes(["GPU_RAY", "no_such_type"]) == {"Lidar"}
    ruled_out = TAX.disagreeing(TAX.declared_classes(["ray"]), "Sensor")
    assert {"VisionSensor", "ContactSensor"} <= ruled_out and not {"RangingSensor", "Lidar", "Sonar"} & ruled_out
    assert TAX.disagreeing(TAX.declared_classes(["ray"]), "EndEffector") == frozenset()


KIND = {"nose_scanner": "sensor", "mast_eye_optical": "sensor", "tail_scanner": "sensor",
        "echo_1_link": "sensor", "echo_2_link": "sensor", "echo_3_link": "sensor"}


def _rover_model(seen: dict[str, Question]):
    """A model that finds every sensor, names the three rangers one device, and always prefers the
    first option it is offered (so only what the code offers decides the class)."""
    def rule(q: Question):
        seen[q.key] = q
        stage, _, subject = q.key.partition(":")
        subject = subject.partition("@")[0]
        if stage == "check":
            return "sensor"
        if stage == "identify":
            return KIND.get(subject, NONE)
        if stage == "device":
            return "echo" if subject.startswith("echo") else subject
        return q.options[0]
    return rule


def test_meshes_and_shapes_reach_classification_but_declarations_only_narrow(bot):
    seen: dict[str, Question] = {}
    Abstractor(Oracle(ScriptedBackend(_rover_model(seen))), TAX).run(bot)
    # the file declares a measuring sensor on every sensor leaf of this rover: identification asks none of them
    assert not any(k.startswith("identify:") for k in seen)
    eye = next(q.user for k, q in seen.items() if k.startswith("pre:mast_eye_optical@"))
    assert "Link: mast_eye_optical (no geometry, massless)" in eye  # its chain below the mount the model chose
    assert "simulated" not in eye  # the camera declaration narrowed the options instead
    # every sensor leaf of this rover carries a declaration (the eye through its plugin's frameName),
    # so the sensor check asks about none of them
    assert not any(k.startswith("check:") for k in seen)


def test_a_declaration_narrows_the_classes_offered_and_is_counted(bot):
    seen: dict[str, Question] = {}
    trace: list[str] = []
    abstractor = Abstractor(Oracle(ScriptedBackend(_rover_model(seen))), TAX, log=trace.append)
    components = {c.subcomponents[-1].link: c for c in abstractor.run(bot).components}
    assert components["nose_scanner"].cls == "Lidar"  # gpu_ray: no question left to ask
    assert "pre:nose_scanner@Sensor" not in seen
    assert seen["pre:tail_scanner@RangingSensor"].options == ("lidar", "sonar", "other ranging sensor")
    assert components["mast_eye_optical"].cls in TAX.subclasses("Camera")  # the first option was "vision"
    assert abstractor.tally.declared >= 4 and any("declared ['gpu_ray']" in line for line in trace)


def test_numbered_units_named_as_one_device_stay_separate_unless_an_array(bot):
    """The three echo rangers, each declared a ray sensor of its own, are never one device; without their
    declarations the model's one device name for them is split by their numbers."""
    for undeclared in (False, True):
        seen: dict[str, Question] = {}
        trace: list[str] = []
        rover = load_urdf(re.sub(rb'<gazebo reference="echo_\d_link">.*?</gazebo>', b"", BOT.read_bytes())) \
            if undeclared else bot
        found = Abstractor(Oracle(ScriptedBackend(_rover_model(seen))), TAX, log=trace.append).run(rover).components
        echoes = [c for c in found if c.subcomponents[0].link.startswith("echo")]
        assert [c.subcomponents[0].link for c in echoes] == ["echo_1_link", "echo_2_link", "echo_3_link"]
        assert all(c.root == "hull" and len(c.subcomponents) == 1 for c in echoes)
        assert {c.cls for c in echoes} == ({echoes[0].cls} if undeclared else {"Lidar"})  # first-option rangers
        assert any(line.startswith("split numbered units") for line in trace) == undeclared


@pytest.mark.parametrize("names, cls, apart", [
    (("button_1", "button_2", "button_power"), "Button", True),
    (("bump_left", "bump_right"), "Bumper", True),
    (("cam_left", "cam_right"), "StereoCamera", False),
    (("button_1", "key_power"), "Button", False),
])
def test_units_whose_names_differ_in_their_last_word_are_separate_unless_one_cameras(names, cls, apart):
    """Bare frames on one base, each by its own joint, named alike but for their last word and given one device name
    by the model, then typed a device of one kind that is no array: a faceplate's three buttons are three buttons, each
    of that kind (on the code before: one button of three frames); a stereo camera's two eyes stay one camera (its
    frames of several places are one device); names of no common stem are no units."""
    w = Writer(random.Random(3))
    base = w.link('<box size="0.4 0.3 0.1"/>')
    for i, name in enumerate(names):
        w.links.append(f'<link name="{name}"/>')
        w.joint("fixed", base, name, (0.1, 0.04 * i, 0.05))
    tree = load_urdf(w.urdf())
    ctx = Abstractor(Oracle(ScriptedBackend(lambda q: q.options[0])), TAX).context(tree, kind="sensor")
    state = Findings(groups=[Group([sub_chain(tree, name, base) for name in names])])
    parent = TAX.parents(cls)[0]
    state.pre = {name: Typed(parent, 0.9) for name in names}
    state.post = [Typed(cls, 0.7)]
    numbered_units(ctx, state)
    if apart:
        assert [g.leaves for g in state.groups] == [[name] for name in names]
        assert [t.cls for t in state.post] == [cls] * len(names)
    else:
        assert [g.leaves for g in state.groups] == [list(names)] and state.post[0].cls == cls


def test_provenance_reports_how_many_decisions_a_declaration_constrained(bot):
    seen: dict[str, Question] = {}
    result = run(bot, Settings(use_cache=False), backend=ScriptedBackend(_rover_model(seen)))
    assert int(result.provenance["declared_constraints"]) >= 4


def _declared_frames(seed: int, sensors: list[str]) -> tuple[bytes, list[str]]:
    """A base with one bare frame of meaningless name per sensor element, each declaring it (`{i}` in it: the
    frame's index, `{leaf}`: its name)."""
    w = Writer(random.Random(seed))
    base = w.link('<box size="0.4 0.3 0.1"/>')
    leaves, gazebo = [], []
    for i, sensor in enumerate(sensors):
        leaf = w.link()
        w.joint("fixed", base, leaf, xyz=(0.2, 0.05 * i, 0.05))
        gazebo.append(f'<gazebo reference="{leaf}">{sensor.format(i=i, leaf=leaf)}</gazebo>')
        leaves.append(leaf)
    return w.urdf().replace(b"</robot>", "".join(gazebo).encode() + b"</robot>"), leaves


def _rangers(seed: int, spans: list[tuple[str, float]]) -> tuple[bytes, list[str]]:
    """A base with one ray sensor per (SDF type, span in degrees), each a bare frame of meaningless name."""
    def ranger(kind: str, degrees: float) -> str:
        half = math.radians(degrees) / 2
        return (f'<sensor name="s{{i}}" type="{kind}"><ray><scan><horizontal><samples>5</samples>'
                f'<min_angle>{-half}</min_angle><max_angle>{half}</max_angle></horizontal></scan>'
                f'<range><min>0.02</min><max>2</max></range></ray></sensor>')
    return _declared_frames(seed, [ranger(kind, degrees) for kind, degrees in spans])


@pytest.mark.parametrize("seed", range(5))
def test_a_declared_span_rules_out_the_ranging_kinds_it_is_too_narrow_for(seed):
    """core:horizontalFieldOfViewRadians restrictions: a lidar sweeps at least 0.6 rad, a sonar's cone spans at least
    0.2 rad; a 10-degree laser beam (a cliff or proximity sensor) is a ranging sensor of no more specific kind."""
    urdf, (beam, cone, wide, scanner) = _rangers(seed, [("gpu_lidar", 10), ("ray", 30), ("ray", 60), ("gpu_ray", 270)])
    seen: dict[str, Question] = {}

    def rule(q: Question):
        seen[q.key] = q
        stage = q.key.partition(":")[0]
        return {"check": "sensor", "identify": "sensor"}.get(stage, q.options[0])

    found = {c.subcomponents[-1].link: c.cls for c in Abstractor(Oracle(ScriptedBackend(rule)), TAX).run(load_urdf(urdf)).components}
    assert found[beam] == "RangingSensor" and found[cone] == "Sonar" and found[scanner] == "Lidar"
    assert seen[f"pre:{wide}@RangingSensor"].options == ("lidar", "sonar", "other ranging sensor")  # both kinds fit 60 degrees
    assert seen[f"pre:{cone}@RangingSensor"].options == ("sonar", "other ranging sensor")  # core:otherAnswer stays offered
    assert not any(k.startswith(f"pre:{beam}@") for k in seen)


def _range_plugins(seed: int, rangers: list[tuple[str, float, float | None]]) -> tuple[bytes, list[str]]:
    """A base with one `ray` sensor per (radiation, plugin cone in rad, scan span in rad or None), each publishing
    sensor_msgs/Range through gazebo_ros_range, each a bare frame of meaningless name."""
    def ranger(radiation: str, cone: float, span: float | None) -> str:
        scan = (f"<scan><horizontal><samples>5</samples><min_angle>{-span / 2}</min_angle><max_angle>{span / 2}"
                f"</max_angle></horizontal></scan>" if span is not None else "")
        return (f'<sensor name="s{{i}}" type="ray"><ray>{scan}<range><min>0.01</min><max>0.2</max></range></ray>'
                f'<plugin filename="libgazebo_ros_range.so" name="p{{i}}"><frameName>{{leaf}}</frameName>'
                f'<radiation>{radiation}</radiation><fov>{cone}</fov></plugin></sensor>')
    return _declared_frames(seed, [ranger(*r) for r in rangers])


@pytest.mark.parametrize("seed", range(5))
def test_what_a_ranging_sensor_emits_rules_out_the_kinds_that_emit_otherwise(seed):
    """core:rangingRadiation values: a sonar emits ultrasound, a lidar infrared light. The erring model answers
    "lidar" first (as the real one did for a small robot's two infrared floor sensors, each a 0.3 rad cone
    stated by its range plugin alone): an infrared cone too narrow for a lidar is a ranging sensor of no more
    specific kind, unasked; an ultrasound cone wide enough for a lidar is offered no lidar."""
    urdf, (floor, wide_sonar, scanned_ir) = _range_plugins(seed, [("infrared", 0.3, None), ("ultrasound", 1.0, 1.05),
                                                                  ("infrared", 0.5, 0.5)])
    seen: dict[str, Question] = {}

    def rule(q: Question):
        seen[q.key] = q
        return {"check": "sensor", "identify": "sensor"}.get(q.key.partition(":")[0], q.options[0])

    trace: list[str] = []
    found = {c.subcomponents[-1].link: c.cls
             for c in Abstractor(Oracle(ScriptedBackend(rule)), TAX, log=trace.append).run(load_urdf(urdf)).components}
    assert found[floor] == "RangingSensor" and not any(k.startswith(f"pre:{floor}@") for k in seen)
    assert seen[f"pre:{wide_sonar}@RangingSensor"].options == ("sonar", "other ranging sensor")
    assert found[wide_sonar] == "Sonar"
    assert found[scanned_ir] == "RangingSensor"  # 0.5 rad of infrared: too narrow for a lidar, and no sonar
    assert any("emitting infrared, not ['Sonar']" in line for line in trace)


@pytest.mark.parametrize("seed", range(5))
def test_each_ranger_declared_on_its_own_is_a_device_of_its_own(seed):
    """The erring model names every ranger by the stem their names share (the real one put a small robot's seven
    infrared proximity sensors, `<stem>_<place>_link`, into two devices): a ray sensor gives one scan or range
    reading, so sub-chains each declaring its own are separate devices."""
    urdf, leaves = _range_plugins(seed, [("infrared", 0.3, None)] * 4)
    stem = "qazu"
    for leaf in leaves:
        urdf = urdf.replace(f'"{leaf}"'.encode(), f'"{stem}_{leaf}"'.encode()).replace(
            f">{leaf}<".encode(), f">{stem}_{leaf}<".encode())
    asked: list[str] = []

    def rule(q: Question):
        asked.append(q.key)
        if q.key.startswith(f"pre:{stem}_mid@Sensor"):
            return "ranging sensor"
        return {"check": "sensor", "identify": "sensor"}.get(q.key.partition(":")[0], q.options[0])

    found = [c for c in Abstractor(Oracle(ScriptedBackend(rule)), TAX).run(load_urdf(urdf)).components
             if c.kind == "sensor"]
    assert sorted(c.subcomponents[-1].link for c in found) == sorted(f"{stem}_{leaf}" for leaf in leaves)
    assert all(c.cls == "RangingSensor" and len(c.subcomponents) == 1 for c in found)
    assert not any(k.startswith("device:") for k in asked)  # no partition left to the names
    # a frame of the same stem that declares nothing, called a ranging sensor, joins one of them at most, never two
    # through itself
    bare = f'<link name="{stem}_mid"/><joint name="{stem}_mid_joint" type="fixed"><parent link="{_base(urdf)}"/>' \
           f'<child link="{stem}_mid"/><origin xyz="0.2 0.07 0.05" rpy="0 0 0"/></joint>'
    found = [c for c in Abstractor(Oracle(ScriptedBackend(rule)), TAX).run(
        load_urdf(urdf.replace(b"</robot>", bare.encode() + b"</robot>"))).components if c.kind == "sensor"]
    assert all(len([s for s in c.subcomponents if s.link != f"{stem}_mid"]) <= 1 for c in found)
    assert sorted(s.link for c in found for s in c.subcomponents if s.link != f"{stem}_mid") == \
        sorted(f"{stem}_{leaf}" for leaf in leaves)


def _base(urdf: bytes) -> str:
    """The first link of a generated robot (its base)."""
    return urdf.split(b'<link name="', 1)[1].split(b'"', 1)[0].decode()


def test_the_ontology_says_what_each_ranging_kind_emits():
    assert TAX.emitting_otherwise("infrared", "RangingSensor") == {"Sonar"}
    assert TAX.emitting_otherwise("ultrasound", "RangingSensor") == {"Lidar"}
    assert TAX.emitting_otherwise("infrared", "Sensor") == {"Sonar"}
    assert TAX.domain("rangingRadiation") == "RangingSensor"


@pytest.mark.parametrize("seed", range(5))
def test_a_leaf_the_file_declares_a_measuring_sensor_on_is_a_sensor_unasked(seed):
    """The erring model calls every leaf a body part (TurtleBot 4's cliff sensors, declared gpu_lidar, were lost so):
    a declared ray, camera or IMU sensor makes its leaf a sensor without a question; a contact declaration on a robot
    that does not roll on wheels (a drone's landing skid reports touching down so) leaves the leaf to the model."""
    urdf, leaves = _rangers(seed, [("gpu_lidar", 5), ("ray", 40), ("contact", 0)])
    asked: list[str] = []

    def rule(q: Question):
        asked.append(q.key)
        return "body part" if q.key.startswith("identify:") else q.options[0]
    abstractor = Abstractor(Oracle(ScriptedBackend(rule)), TAX)
    found = {c.subcomponents[-1].link for c in abstractor.run(load_urdf(urdf)).components if c.kind == "sensor"}
    assert found == set(leaves[:2])
    assert [k for k in asked if k.startswith("identify:")] == [f"identify:{leaves[2]}"]


def test_a_link_drawn_for_collision_alone_is_told_from_one_drawn_to_be_seen():
    urdf = (b'<robot name="r"><link name="a"><visual><geometry><box size="1 1 1"/></geometry></visual>'
            b'<collision><geometry><box size="1 1 1"/></geometry></collision></link>'
            b'<link name="b"><collision><geometry><sphere radius="0.1"/></geometry></collision></link><link name="c"/>'
            b'<joint name="j" type="fixed"><parent link="a"/><child link="b"/></joint>'
            b'<joint name="k" type="fixed"><parent link="a"/><child link="c"/></joint></robot>')
    evidence = load_urdf(urdf).evidence
    assert [evidence[link].collision_only for link in "abc"] == [False, True, False]


def _depth_camera(seed: int, image_topic: str) -> tuple[bytes, str]:
    """A base with a camera body and its optical frame, meaningless names; a Gazebo classic depth sensor on the body
    whose openni plugin publishes its image on `image_topic` (and depth beside it) in the optical frame."""
    w = Writer(random.Random(seed))
    base = w.link('<box size="0.4 0.3 0.1"/>')
    body, frame = w.link('<box size="0.03 0.18 0.03"/>'), w.link()
    w.joint("fixed", base, body, xyz=(0.2, 0.0, 0.3))
    w.joint("fixed", body, frame, xyz=(0.0, 0.02, 0.0), rpy=(-math.pi / 2, 0.0, -math.pi / 2))
    gazebo = (f'<gazebo reference="{body}"><sensor name="s" type="depth"><camera><horizontal_fov>1.0</horizontal_fov>'
              f'<image><format>B8G8R8</format><width>640</width><height>480</height></image></camera>'
              f'<plugin name="p" filename="libgazebo_ros_openni_kinect.so"><imageTopicName>{image_topic}</imageTopicName>'
              f'<depthImageTopicName>depth/image_raw</depthImageTopicName><frameName>{frame}</frameName></plugin>'
              f'</sensor></gazebo>')
    return w.urdf().replace(b"</robot>", gazebo.encode() + b"</robot>"), frame


@pytest.mark.parametrize("seed", range(3))
@pytest.mark.parametrize("topic, colour", [
    ("color/image_raw", True), ("/head_camera/rgb/image_raw", True), ("rgbd/image_rect_color", True),
    ("ir/image_raw", False), ("image_raw", False), ("/scene/colorless_map", False),
    ("aligned_depth_to_color/image_raw", False)])
def test_a_depth_sensor_publishing_colour_is_an_rgbd_camera_whatever_the_model_says(seed, topic, colour):
    """The real model read a RealSense's declared depth sensor (its openni plugin publishing color/image_raw) as a depth
    camera: a depth declaration whose image topic is in the colour stream amounts to SDF's rgbd_camera and rules the
    depth camera out; an infrared or unnamed image leaves the choice to the model."""
    urdf, frame = _depth_camera(seed, topic)
    tree = load_urdf(urdf)
    (sensor,) = tree.evidence[frame].sensors
    assert sensor.colour is colour and sensor.sdf_type == ("rgbd_camera" if colour else "depth")

    def rule(q: Question):  # finds the sensor and prefers a depth camera wherever one is offered
        stage = q.key.partition(":")[0]
        if stage in ("check", "identify"):
            return "sensor"
        return "depth camera" if "depth camera" in q.options else q.options[0]
    (camera,) = Abstractor(Oracle(ScriptedBackend(rule)), TAX).run(tree).components
    assert camera.cls == ("RGBDCamera" if colour else "DepthCamera")


def _seeing_depth(base: str, asked: dict[str, Question] | None = None):
    """A model that finds the sensors, mounts them on `base`, names one device, and sees depth wherever it is
    offered: a depth camera of depth frames (as the real model did); each question into `asked`."""
    def rule(q: Question):
        if asked is not None:
            asked[q.key] = q
        stage = q.key.partition(":")[0]
        if stage in ("check", "identify"):
            return "sensor"
        if stage == "root":
            return base
        if stage == "device":
            return min(q.options, key=len)
        return next((o for o in q.options if o.startswith("depth ")), q.options[0])
    return rule


@pytest.mark.parametrize("seed", range(3))
@pytest.mark.parametrize("pixels, together, colour", [("B8G8R8", True, True), ("RGB_INT8", True, True),
                                                      ("L8", True, False), ("L_INT8", True, False),
                                                      ("B8G8R8", False, True)])
def test_a_depth_sensor_beside_a_colour_camera_of_one_device_is_an_rgbd_camera(seed, pixels, together, colour):
    """A torso camera written as the simulator's plain camera and a depth sensor of no topics on one imager's frame,
    a monochrome camera on the other's, all under one housing, was typed a depth camera: a camera giving colour and a
    depth sensor declared on one link are one device's, SDF's rgbd_camera, and so are the device's other imagers;
    with the colour camera declared on the other imager, its format still says colour beside the depth. Beside a
    monochrome camera alone, the model decides (a model seeing depth wherever it is offered: a depth camera; the
    monochrome imager offered no colour image)."""
    w = Writer(random.Random(seed))
    base = w.link('<box size="0.4 0.3 0.1"/>')
    housing = w.link('<box size="0.03 0.12 0.03"/>')
    w.joint("fixed", base, housing, xyz=(0.2, 0.0, 0.3))
    imagers = [w.link(), w.link()]
    for side, imager in zip((1, -1), imagers):
        w.joint("fixed", housing, imager, xyz=(0.0, 0.025 * side, 0.0))

    def sensor(kind: str, fmt: str) -> str:
        return (f'<sensor name="{kind}" type="{kind}"><camera><horizontal_fov>1.2</horizontal_fov><image>'
                f'<format>{fmt}</format><width>640</width><height>400</height></image></camera>'
                f'<plugin name="{kind}_p" filename="libgazebo_ros_camera.so"/></sensor>')
    first, second = (sensor("camera", pixels), sensor("camera", "L8"))[::1 if together else -1]
    gazebo = (f'<gazebo reference="{imagers[0]}">{first}{sensor("depth", "B8G8R8")}</gazebo>'
              f'<gazebo reference="{imagers[1]}">{second}</gazebo>')
    urdf = w.urdf().replace(b"</robot>", gazebo.encode() + b"</robot>")
    for imager in imagers:  # the imagers' names begin with the housing's, so the model can name one device
        urdf = urdf.replace(f'"{imager}"'.encode(), f'"{housing}_{imager}"'.encode())
    tree = load_urdf(urdf)

    cameras = Abstractor(Oracle(ScriptedBackend(_seeing_depth(base))), TAX).run(tree).components
    assert [c.cls for c in cameras] == ["RGBDCamera" if colour else "DepthCamera"]


def _legged(seed: int, pose: str | None, own: bool = False) -> tuple[bytes, str, str]:
    """A pelvis on two three-joint legs, each foot carrying a frame at (0.02, 0, -0.05) and a sole frame below; the
    left ankle declares a force-torque sensor at `pose` (Gazebo's way: on the joint); `own`: that frame declares an
    IMU of its own. (urdf, that frame, the sole)"""
    w = Writer(random.Random(seed))
    pelvis = w.link('<box size="0.2 0.3 0.1"/>', centre=(0, 0, 0), mass=5)
    frames = []
    for y in (0.1, -0.1):
        hip, knee, foot = (w.link('<box size="0.05 0.05 0.3"/>', centre=(0, 0, -0.15)) for _ in range(3))
        w.joint("revolute", pelvis, hip, (0, y, -0.05), (1, 0, 0))
        w.joint("revolute", hip, knee, (0, 0, -0.3), (0, 1, 0))
        ankle = w.joint("revolute", knee, foot, (0, 0, -0.3), (0, 1, 0))
        at, sole = w.link(), w.link()
        w.joint("fixed", foot, at, (0.02, 0, -0.05))
        w.joint("fixed", foot, sole, (0, 0, -0.08))
        frames.append((ankle, at, sole))
    (ankle, at, sole), _ = frames
    stated = f"<pose>{pose}</pose>" if pose is not None else ""
    block = (f'<gazebo reference="{ankle}"><sensor name="{w.name()}" type="force_torque">{stated}'
             '<update_rate>500</update_rate></sensor></gazebo>')
    if own:
        block += f'<gazebo reference="{at}"><sensor name="{w.name()}" type="imu"/></gazebo>'
    return w.urdf().replace(b"</robot>", block.encode() + b"</robot>"), at, sole


@pytest.mark.parametrize("seed", range(3))
def test_a_sensor_declared_on_a_joint_is_the_frame_its_pose_puts_it_on(seed, tmp_path):
    urdf, at, sole = _legged(seed, "0.02 0 -0.05 3.14 0 0")
    (tmp_path / "legs.urdf").write_bytes(urdf)
    tree = load_urdf(tmp_path / "legs.urdf")
    [ft] = tree.evidence[at].sensors
    assert (ft.type, ft.reference, ft.rate) == ("force_torque", at, 500.0)
    assert [link for link, facts in tree.evidence.items() if facts.sensors] == [at]
    found = run(tree, Settings(use_cache=False), backend=ScriptedBackend(
        lambda q: NONE if q.key.startswith("identify:") else q.options[0])).components
    assert [(c.cls, c.links) for c in found] == [("ForceTorqueSensor", (at,))]  # the soles stay the feet's


def test_a_joint_sensor_placed_nowhere_a_frame_is_belongs_to_no_link(tmp_path):
    """No pose (iCub's force-torque joints between two bodies), a pose at the joint itself (the copied zero), or one
    where no frame sits: no link declares it."""
    for pose in (None, "0 0 0 0 0 0", "0.3 0 0 0 0 0"):
        urdf, _, _ = _legged(0, pose)
        (tmp_path / "legs.urdf").write_bytes(urdf)
        assert not any(facts.sensors for facts in load_urdf(tmp_path / "legs.urdf").evidence.values())


@pytest.mark.parametrize("pose", [None, "0 0 0 3.14159 0 -1.5708"])
@pytest.mark.parametrize("seed", range(3))
def test_a_joint_sensor_at_its_joint_is_the_frame_written_where_that_joint_is(seed, pose, tmp_path):
    """An arm whose force-torque sensor is declared on the fixed joint between two of its bodies, at the joint (no
    pose, or a zero one), with its measurement frame written beside it: a bare frame fixed on the joint's parent at
    the joint's origin (as a humanoid's files write each of theirs). That frame declares the sensor, and the model
    that calls every leaf none still gets a force-torque sensor there; a frame elsewhere on that parent does not."""
    w = Writer(random.Random(seed))
    base = w.link('<box size="0.2 0.2 0.2"/>')
    shoulder, upper, forearm = (w.link('<box size="0.05 0.05 0.2"/>') for _ in range(3))
    w.joint("revolute", base, shoulder, (0, 0, 0.1), (0, 0, 1))
    at = (round(random.Random(seed).uniform(-0.01, 0.01), 4), 0.0, -0.05)
    joint = w.joint("fixed", shoulder, upper, at)
    w.joint("revolute", upper, forearm, (0, 0, -0.2), (0, 1, 0))
    frame, elsewhere = w.link(), w.link()
    w.joint("fixed", shoulder, frame, at, rpy=(3.14159, 0.0, -1.5708))
    w.joint("fixed", shoulder, elsewhere, (0.03, 0.0, 0.0))
    stated = f"<pose>{pose}</pose>" if pose is not None else ""
    block = f'<gazebo reference="{joint}"><sensor name="ft" type="force_torque">{stated}</sensor></gazebo>'
    (tmp_path / "arm.urdf").write_bytes(w.urdf().replace(b"</robot>", block.encode() + b"</robot>"))
    tree = load_urdf(tmp_path / "arm.urdf")
    assert [link for link, facts in tree.evidence.items() if facts.sensors] == [frame]
    found = run(tree, Settings(use_cache=False), backend=ScriptedBackend(
        lambda q: NONE if q.key.startswith("identify:") else q.options[0])).components
    assert [(c.cls, c.links) for c in found if c.kind == "sensor"] == [("ForceTorqueSensor", (frame,))]


@pytest.mark.parametrize("seed", range(3))
def test_two_force_torque_sensors_each_declared_on_one_foot_are_two_devices(seed, tmp_path):
    """A foot carrying a front and a rear force-torque frame, each declaring its own sensor, named alike: the model
    names both the foot's one device; each declaration is one transducer, so they are two sensors."""
    w = Writer(random.Random(seed))
    pelvis = w.link('<box size="0.2 0.3 0.1"/>')
    link = pelvis
    for _ in range(3):
        child = w.link('<box size="0.05 0.05 0.3"/>')
        w.joint("revolute", link, child, (0, 0, -0.3), (0, 1, 0))
        link = child
    frames = ["l_foot_front_ft", "l_foot_rear_ft"]
    w.links += [f'<link name="{f}"/>' for f in frames]
    for f, x in zip(frames, (0.1, -0.03)):
        w.joint("fixed", link, f, (x, 0, -0.05))
    block = "".join(f'<gazebo reference="{f}"><sensor name="{f}" type="force_torque"/></gazebo>' for f in frames)
    (tmp_path / "leg.urdf").write_bytes(w.urdf().replace(b"</robot>", block.encode() + b"</robot>"))
    found = run(load_urdf(tmp_path / "leg.urdf"), Settings(use_cache=False), backend=ScriptedBackend(
        lambda q: NONE if q.key.startswith("identify:") else q.options[0])).components
    assert sorted((c.cls, c.links) for c in found if c.kind == "sensor") == [
        ("ForceTorqueSensor", (frames[0],)), ("ForceTorqueSensor", (frames[1],))]


@pytest.mark.parametrize("seed", range(3))
def test_a_frame_is_offered_only_the_images_its_declared_camera_gives(seed):
    """A tracking camera's two fisheye optical frames, each declaring SDF's wide-angle camera, 6 cm apart under one
    housing; a model that sees depth wherever it is offered (as the real one did): no depth image is offered, so
    the two frames make a stereo camera, not an RGB-D one. A frame whose camera states L8 is offered no colour."""
    w = Writer(random.Random(seed))
    base = w.link('<box size="0.4 0.3 0.1"/>')
    housing = w.link('<box size="0.02 0.1 0.02"/>')
    w.joint("fixed", base, housing, xyz=(0.2, 0.0, 0.3))
    eyes = [w.link(), w.link()]
    for side, eye in zip((1, -1), eyes):
        w.joint("fixed", housing, eye, xyz=(0.0, 0.03 * side, 0.0), rpy=(-math.pi / 2, 0.0, -math.pi / 2))
    pixels = ("", "<image><format>L8</format></image>")
    gazebo = "".join(f'<gazebo reference="{eye}"><sensor name="{w.name()}" type="wideanglecamera"><camera>{fmt}'
                     '</camera></sensor></gazebo>' for eye, fmt in zip(eyes, pixels))
    urdf = w.urdf().replace(b"</robot>", gazebo.encode() + b"</robot>")
    for eye in eyes:
        urdf = urdf.replace(f'"{eye}"'.encode(), f'"{housing}_{eye}"'.encode())
    tree = load_urdf(urdf)
    asked: dict[str, Question] = {}
    [camera] = Abstractor(Oracle(ScriptedBackend(_seeing_depth(base, asked))), TAX).run(tree).components
    assert camera.cls == "StereoCamera"
    first, second = (f"{housing}_{eye}" for eye in eyes)
    assert {s.link: s.cls for s in camera.subcomponents if s.link != housing} == {first: "RgbFrame",
                                                                                   second: "InfraredFrame"}
    assert not any(o.startswith("depth ") for k, q in asked.items() if k.startswith("part:") for o in q.options)


def test_a_joint_sensor_at_a_frame_declaring_its_own_sensor_is_not_that_frames(tmp_path):
    """A foot's IMU frame sits where the ankle's force-torque sensor is declared: it stays an IMU alone."""
    urdf, at, _ = _legged(1, "0.02 0 -0.05 3.14 0 0", own=True)
    (tmp_path / "legs.urdf").write_bytes(urdf)
    assert [s.type for s in load_urdf(tmp_path / "legs.urdf").evidence[at].sensors] == ["imu"]
