"""The gates before population (pipeline.knowledge.screen): a component or body part that breaks the shapes, or a
sensor under the confidence floor, is held back for review, never silently written: the trace records it with
the reason, the review page lists it, and the robot written without it passes the shapes as a whole."""
from __future__ import annotations

import json
from dataclasses import replace
from io import StringIO

import owlready2

from tests.kb_fixtures import client, make_app
from tests.placement_robot import LABELS, TAX, build, model
from tests.sample_bot import sample_abstraction, sample_tree
from tests.scripted_reasoner import scripted_placements, scripted_reasoner
from urdfkb.pipeline.abstraction.components import END_EFFECTOR, Abstraction, BodyPart, Component, Held, SubComponent
from urdfkb.pipeline.knowledge.export import robot_graph
from urdfkb.pipeline.reading.ingest import load_urdf
from urdfkb.pipeline.llm.scripted import ScriptedBackend
from urdfkb.pipeline.knowledge.population import build_robot
from urdfkb.pipeline.runner import Settings, run
from urdfkb.pipeline.knowledge.screen import SENSOR_FLOOR, hold_bodiless, hold_unsure, screen
from urdfkb.pipeline.knowledge.shacl import validate

HTML = {"Accept": "text/html"}


def conforms(tree, abstraction: Abstraction) -> bool:
    ok, report = validate(robot_graph(build_robot(owlready2.World(), tree, "bot", abstraction)))
    assert ok, report
    return ok


def populated(trace: StringIO):
    """The placement robot (tests/placement_robot.py) through runner.run: the loop asks the torso's button again,
    and this model then calls it a monocular camera, though its one link was typed a sensing element when it
    was a bumper: a camera without an optical frame."""
    robot = build(0)
    rule = model(robot, [])

    def camera_when_asked_again(q):
        if q.key.startswith(f"placement:{robot.button}@"):
            return next(o for o in q.options if TAX.is_a("MonocularCamera", LABELS[o]))
        return rule(q)
    tree = load_urdf(robot.urdf)
    abstraction = run(tree, Settings(use_cache=False), backend=ScriptedBackend(camera_when_asked_again), trace=trace,
                      reasoner=scripted_reasoner, placer=scripted_placements)
    return robot, tree, abstraction


def test_a_camera_without_an_optical_frame_is_held_back_and_traced_not_written():
    trace = StringIO()
    robot, tree, abstraction = populated(trace)
    (held,) = abstraction.held
    assert (held.kind, held.cls, held.links) == ("sensor", "MonocularCamera", (robot.button,))
    assert {v.split(":")[0] for v in held.violations} == {"CameraShape", "ModalityShape"}
    assert f"CameraShape: comp_{held.name} hasOpticalFrame: a camera needs at least one optical frame (hasOpticalFrame)" \
        in held.violations
    assert held.name not in {c.name for c in abstraction.components}
    assert robot.bumper in {link for c in abstraction.components for link in c.links}  # the rest is written
    records = [json.loads(line) for line in trace.getvalue().splitlines()]
    assert [(r["name"], r["class"], r["shapes"]) for r in records if r["key"] == "held" and r["why"] == "shapes"] == [
        (held.name, "MonocularCamera", ["CameraShape", "ModalityShape"])]
    assert conforms(tree, abstraction)


def test_the_review_page_lists_what_was_held_back_with_the_shapes_message(store):
    _, tree, abstraction = populated(StringIO())
    store.replace_robot("placed", tree, abstraction)
    assert store.source("placed")[1].held == abstraction.held
    app, jobs = make_app(store)
    try:
        status, _, body = client(app)("GET", "/robots/placed", headers=HTML)
    finally:
        jobs.shutdown()
    page = body.decode()
    assert status == 200 and 'id="held"' in page and abstraction.held[0].name in page
    assert "a camera needs at least one optical frame (hasOpticalFrame)" in page


def test_a_camera_whose_optical_frame_has_no_modality_is_held_back():
    """The model gave no modality (its frame stays an OpticalFrame): held, the gripper written."""
    tree = sample_tree()
    abstraction = sample_abstraction(rgb_cls="OpticalFrame")
    camera = abstraction.components[0]
    no_modality = replace(abstraction, components=(replace(camera, subcomponents=camera.subcomponents[:1]),
                                                   abstraction.components[1]))
    screened = screen(tree, no_modality)
    assert [(h.name, h.violations) for h in screened.held] == [
        ("head camera", ("ModalityShape: comp_head%20camera: a camera needs an optical frame of a modality: "
                         "RGB, depth or infrared",))]
    assert [c.name for c in screened.components] == ["gripper"] and conforms(tree, screened)


def test_a_body_part_without_joints_or_links_is_held_and_what_it_carried_lets_go():
    """A component located on it loses that location, a part under it hangs from the robot."""
    tree = sample_tree()
    empty = BodyPart("head", "Head", 1.0, "base_link", (), ())
    wheel = BodyPart("wrist", "Wheel", 1.0, "base_link", ("wrist_joint",), ("wrist_link",), parent="head")
    camera, gripper = sample_abstraction().components
    abstraction = Abstraction((replace(camera, located_on="head", side="left"), gripper), body=(empty, wheel))
    screened = screen(tree, abstraction)
    assert screened.held == (Held("head", None, "Head", (), ("BodyPartShape: body_head: a body part needs at least "
                                                               "one joint or link",)),)
    assert screened.body == (replace(wheel, parent=None),)
    assert (screened.components[0].located_on, screened.components[0].side) == (None, None)
    assert conforms(tree, screened)


def test_a_robot_that_conforms_is_left_as_it_is():
    abstraction = sample_abstraction()
    assert screen(sample_tree(), abstraction) is abstraction


def test_a_sensor_under_the_floor_is_held_and_a_tool_never():
    """Under SENSOR_FLOOR a sensor is held with the reason; at the floor it is written; a tool under it is written."""
    camera, gripper = sample_abstraction().components
    unsure = Abstraction((replace(camera, confidence=SENSOR_FLOOR - 0.01), replace(gripper, confidence=0.05)))
    records: list[dict] = []
    held = hold_unsure(sample_tree(), unsure, records.append)
    assert [c.name for c in held.components] == ["gripper"]
    assert held.held == (Held("head camera", "sensor", "RGBDCamera", camera.links,
                              (f"SensorFloor: head camera: confidence {SENSOR_FLOOR - 0.01:.2f} is under "
                               f"{SENSOR_FLOOR}, the least a sensor is written with",)),)
    assert [(r["why"], r["name"]) for r in records] == [("floor", "head camera")]
    at_floor = Abstraction((replace(camera, confidence=SENSOR_FLOOR), gripper))
    assert hold_unsure(sample_tree(), at_floor) == at_floor


def test_a_sensor_under_the_floor_the_file_declares_is_written():
    """A camera body the file declares a camera on, its optical frame below it, read by the model as a monocular
    camera at 0.15: the file states a camera, so it is written (in the review queue); a declaration of another kind
    on its body (a contact sensor) states no camera, and it is held (on the code before: held either way)."""
    for sdf_type, kept in (("camera", True), ("contact", False)):
        tree = load_urdf(f"""<robot name="r"><link name="base"><visual><geometry><box size="0.3 0.3 0.1"/></geometry>
            </visual></link><link name="cam"><visual><geometry><box size="0.02 0.05 0.02"/></geometry></visual></link>
            <link name="cam_optical"/><joint name="a" type="fixed"><parent link="base"/><child link="cam"/></joint>
            <joint name="b" type="fixed"><parent link="cam"/><child link="cam_optical"/></joint>
            <gazebo reference="cam"><sensor name="s" type="{sdf_type}"/></gazebo></robot>""".encode())
        camera = Component("camera", "sensor", "MonocularCamera", 0.15, "base",
                           (SubComponent("cam", "SensorHousing", 0.9), SubComponent("cam_optical", "RgbFrame", 0.9)))
        screened = hold_unsure(tree, Abstraction((camera,)))
        assert (screened.components == (camera,)) == kept and (screened.held == ()) == kept


def _arm_end(bracket: bool) -> tuple:
    """An arm's last link, moved by its wrist joint, with two bare frames (a flange, then a tool frame) on it, or on
    a drawn bracket fixed below it."""
    mount = '<link name="bracket"><visual><geometry><box size="0.05 0.05 0.1"/></geometry></visual></link>' \
        '<joint name="jb" type="fixed"><parent link="wrist"/><child link="bracket"/></joint>' if bracket else ""
    on = "bracket" if bracket else "wrist"
    urdf = ('<robot name="arm"><link name="base"><visual><geometry><box size="0.1 0.1 0.1"/></geometry></visual></link>'
            '<link name="wrist"><visual><geometry><cylinder radius="0.04" length="0.1"/></geometry></visual></link>'
            '<joint name="jw" type="revolute"><parent link="base"/><child link="wrist"/><axis xyz="0 0 1"/>'
            '<limit lower="-3" upper="3" effort="1" velocity="1"/></joint>' + mount +
            f'<link name="flange"/><joint name="jf" type="fixed"><parent link="{on}"/><child link="flange"/></joint>'
            '<link name="tool0"/><joint name="jt" type="fixed"><parent link="flange"/><child link="tool0"/>'
            '<origin xyz="0 0 0.02"/></joint></robot>')
    tool = Component("tool", END_EFFECTOR, "EndEffector", 0.3, on,
                     (SubComponent("flange", "ToolHousing", 0.3), SubComponent("tool0", "ToolCenterPoint", 0.3)))
    return load_urdf(urdf.encode()), tool


def test_a_tool_of_no_kind_made_of_bare_frames_on_the_arms_last_moving_link_is_held():
    """An arm carrying no tool ends in bare frames (a flange, tool0) the model takes for a tool it can give no kind:
    nothing of a tool is drawn, so it is held with its reason; the same frames below a drawn bracket fixed on the
    arm (a spindle's tip), or typed a kind of gripper, are written."""
    tree, tool = _arm_end(bracket=False)
    records: list[dict] = []
    held = hold_bodiless(tree, Abstraction((tool,)), "EndEffector", records.append)
    assert held.components == () and [h.name for h in held.held] == ["tool"]
    assert held.held[0].violations[0].startswith("BodilessTool: tool:") and records[0]["why"] == "bodiless"
    gripper = Abstraction((replace(tool, cls="ParallelGripper"),))
    assert hold_bodiless(tree, gripper, "EndEffector") == gripper
    tree, on_bracket = _arm_end(bracket=True)
    assert hold_bodiless(tree, Abstraction((on_bracket,)), "EndEffector") == Abstraction((on_bracket,))


def test_a_frame_the_model_hardly_takes_for_a_sensor_is_held_by_the_run():
    """The placement robot, its model hedging on the torso's frame as a real one hedges on a lamp or a logo: a
    sensor for a minority of the votes, of a class it splits: held back and traced; the rest written."""
    robot = build(0)
    rule = model(robot, [])

    def hedging(q):
        answer = rule(q)
        if q.key.partition(":")[2].partition("@")[0] != robot.button:
            return answer
        answer = "button" if "button" in q.options else answer  # no bumper on the torso: nothing asked again
        if q.key.startswith("identify:"):
            return {"sensor": 0.4, "none": 0.35, "body part": 0.25}
        if q.key.startswith("check:"):
            return {"sensor": 0.55, "emitter": 0.45}
        rest = [o for o in q.options if o != answer]
        return {answer: 0.45, **{o: 0.55 / len(rest) for o in rest}}
    trace = StringIO()
    tree = load_urdf(robot.urdf)
    abstraction = run(tree, Settings(use_cache=False), backend=ScriptedBackend(hedging), trace=trace,
                      reasoner=scripted_reasoner, placer=scripted_placements)
    (held,) = abstraction.held
    assert held.links == (robot.button,) and held.violations[0].startswith("SensorFloor: ")
    assert robot.button not in {link for c in abstraction.components for link in c.links}
    assert robot.bumper in {link for c in abstraction.components for link in c.links}
    records = [json.loads(line) for line in trace.getvalue().splitlines()]
    assert [(r["why"], r["name"]) for r in records if r["key"] == "held"] == [("floor", held.name)]
    assert conforms(tree, abstraction)
