"""What each part can do (pipeline.abstraction.capabilities), on small hand-built trees with known answers and on PR2
populated with its hand-written body (kb_fixtures.PR2_WHOLE and its left forearm camera): optical and
reference frames, declared specifications, reach, gripper opening, head ranges; the export stays consistent
and in OWL 2 DL."""
from __future__ import annotations

import math
import subprocess
from dataclasses import replace
from pathlib import Path

import numpy as np
import owlready2
import owlready2.reasoning
import pytest
import rdflib
import yourdfpy
from rdflib.namespace import OWL, RDF, RDFS

from tests.kb_fixtures import PR2, PR2_ARM, PR2_WHOLE
from urdfkb.pipeline.abstraction import capabilities
from urdfkb.pipeline.abstraction.components import SENSOR, Abstraction, Component, SubComponent
from urdfkb.pipeline.errors import OntologyError
from urdfkb.pipeline.reading.evidence import LinkEvidence, SimSensor
from urdfkb.pipeline.reading.ingest import load_urdf
from urdfkb.pipeline.knowledge.namespaces import CORE, SCHEMA, SSN_SYSTEM, robot_iri
from urdfkb.pipeline.knowledge.ontology import vocabulary
from urdfkb.pipeline.knowledge.population import build_robot
from urdfkb.pipeline.reading.tree import Edge, KinematicTree, Origin

TAX = vocabulary()
DL_CHECK = Path(__file__).parent / "data" / "OWL2DLCheck.java"


def _at(x=0.0, y=0.0, z=0.0, rpy=(0.0, 0.0, 0.0)) -> Origin:
    return Origin((x, y, z), rpy)


def planar_arm(elbow: tuple[float, float]) -> KinematicTree:
    """base → (0.1 up) shoulder, turning about z within ±1 → 0.3 m upper arm → elbow within `elbow` → 0.2 m to the hand."""
    return KinematicTree("planar", ("base", "upper", "fore", "hand"), (
        Edge("shoulder", "revolute", "base", "upper", _at(z=0.1), (0.0, 0.0, 1.0), (-1.0, 1.0)),
        Edge("elbow", "revolute", "upper", "fore", _at(x=0.3), (0.0, 0.0, 1.0), elbow),
        Edge("wrist", "fixed", "fore", "hand", _at(x=0.2))))


def test_reach_is_the_largest_distance_within_the_limits():
    assert capabilities.reach(planar_arm((-2.0, 0.5)), "shoulder", "hand") == pytest.approx(0.5)  # straight
    bent = math.sqrt(0.3 ** 2 + 0.2 ** 2 + 2 * 0.3 * 0.2 * math.cos(0.5))  # the elbow cannot straighten past 0.5 rad
    assert capabilities.reach(planar_arm((0.5, 1.0)), "shoulder", "hand") == pytest.approx(bent)
    assert capabilities.reach(planar_arm((0.5, 1.0)), "elbow", "upper") is None  # not below that joint


def test_a_continuous_joint_its_file_bounds_reaches_within_its_range():
    """An elbow written continuous with a range of under half a turn (as a linkage's bars are written) moves within
    that range; written continuous without one, it turns all the way and the arm reaches straight out."""
    bounded = replace(planar_arm((0.5, 1.0)), edges=tuple(replace(e, joint_type="continuous") if e.joint == "elbow"
                                                               else e for e in planar_arm((0.5, 1.0)).edges))
    free = replace(bounded, edges=tuple(replace(e, limits=None) if e.joint == "elbow" else e for e in bounded.edges))
    bent = math.sqrt(0.3 ** 2 + 0.2 ** 2 + 2 * 0.3 * 0.2 * math.cos(0.5))
    assert capabilities.reach(bounded, "shoulder", "hand") == pytest.approx(bent)
    assert capabilities.reach(free, "shoulder", "hand") == pytest.approx(0.5)


def slide_gripper(upper: float = 0.04, mimic: bool = True) -> KinematicTree:
    """A palm with two jaws sliding apart along ±y, the right one following the left by <mimic>."""
    return KinematicTree("slider", ("palm", "left", "right"), (
        Edge("left_joint", "prismatic", "palm", "left", _at(y=0.01), (0.0, 1.0, 0.0), (0.0, upper)),
        Edge("right_joint", "prismatic", "palm", "right", _at(y=-0.01), (0.0, -1.0, 0.0), (0.0, upper),
             mimic="left_joint" if mimic else None)))


def test_a_gripper_opens_by_its_finger_joints_strokes():
    assert capabilities.opening(slide_gripper(), ["palm", "left", "right"]) == pytest.approx(0.08)
    assert capabilities.opening(slide_gripper(0.025, mimic=False), ["palm", "left", "right"]) == pytest.approx(0.05)
    assert capabilities.opening(planar_arm((0.0, 1.0)), ["fore", "hand"]) is None  # no opposing fingers


def test_head_pan_and_tilt_ranges_from_the_axes_of_its_joints():
    head = KinematicTree("head", ("torso", "neck", "skull"), (
        Edge("pan", "revolute", "torso", "neck", _at(z=0.4), (0.0, 0.0, 1.0), (-1.0, 1.0)),
        Edge("tilt", "revolute", "neck", "skull", _at(x=0.05), (0.0, 1.0, 0.0), (-0.5, 0.8))))
    assert capabilities.head_ranges(head, ["pan", "tilt"]) == (pytest.approx(2.0), pytest.approx(1.3))
    spinning = KinematicTree("spin", ("torso", "neck"), (Edge("pan", "continuous", "torso", "neck", _at(), (0.0, 0.0, -1.0)),))
    assert capabilities.head_ranges(spinning, ["pan"]) == (pytest.approx(2 * math.pi), None)


def _camera_tree(*declarations: SimSensor) -> KinematicTree:
    evidence = {"eye": LinkEvidence(sensors=declarations), "eye_optical": LinkEvidence(sensors=declarations)}
    return KinematicTree("eyes", ("head", "eye", "eye_optical"), (
        Edge("eye_joint", "fixed", "head", "eye", _at()),
        Edge("optical_joint", "fixed", "eye", "eye_optical", _at(rpy=(-math.pi / 2, 0.0, -math.pi / 2)))), evidence)


EYE = Component("eye", SENSOR, "MonocularCamera", 0.9, "head",
                (SubComponent("eye", "SensorHousing", 0.9), SubComponent("eye_optical", "RgbFrame", 0.9)))


def test_a_sensor_takes_what_its_declarations_agree_on_and_the_frame_they_name():
    small = SimSensor("camera", (), "eye", "eye_optical", rate=30.0, fov=1.2, image=(640, 480))
    spec = capabilities.sensor_spec(_camera_tree(small, replace(small, reference="head", rate=None)), TAX, EYE)
    assert spec == capabilities.SensorSpec(("eye_optical",), rate=30.0, fov=1.2, image=(640, 480))
    spec = capabilities.sensor_spec(_camera_tree(small, replace(small, image=(1280, 960))), TAX, EYE)
    assert (spec.image, spec.fov) == (None, 1.2)  # two image sizes: neither is the camera's


def test_without_a_declaration_the_reference_frame_is_its_optical_frame_and_a_foreign_one_is_ignored():
    bumper = SimSensor("contact", (), "eye", rate=100.0)  # a contact declaration says nothing of a camera
    assert capabilities.sensor_spec(_camera_tree(bumper), TAX, EYE) == capabilities.SensorSpec(("eye_optical",))
    ranger = Component("ranger", SENSOR, "Sonar", 0.9, "head", (SubComponent("eye", "SensorHousing", 0.9),
                                                                  SubComponent("eye_optical", "SensingElement", 0.9)))
    assert capabilities.sensor_spec(_camera_tree(), TAX, ranger).reference_frames == ("eye_optical",)


# --- PR2 --------------------------------------------------------------------------------------------

L_FOREARM_CAM = Component("l_forearm_cam", SENSOR, "MonocularCamera", 0.9, "l_forearm_roll_link",
                          (SubComponent("l_forearm_cam_optical_frame", "RgbFrame", 0.9),), located_on="l_arm", side="left")
PR2_BOTH_CAMERAS = replace(PR2_WHOLE, components=(*PR2_WHOLE.components, L_FOREARM_CAM))


@pytest.fixture(scope="module")
def pr2_urdf(shared) -> Path:
    return shared / "urdf" / "pr2.urdf"


@pytest.fixture(scope="module")
def pr2(pr2_tree):
    return build_robot(owlready2.World(), pr2_tree, "pr2", PR2_BOTH_CAMERAS)


@pytest.fixture(scope="module")
def graph(pr2) -> rdflib.Graph:
    from urdfkb.pipeline.knowledge.export import robot_graph
    return robot_graph(pr2)


R = rdflib.Namespace(robot_iri("pr2"))


def _type(graph, node) -> rdflib.URIRef:
    """The class a populated individual was written with (not owl:NamedIndividual)."""
    [cls] = [t for t in graph.objects(node, RDF.type) if t != OWL.NamedIndividual]
    return cls


def _names(graph, subject, prop) -> set[str]:
    return {str(graph.value(o, CORE.urdfName) or graph.value(graph.value(o, CORE.hasLink), CORE.urdfName))
            for o in graph.objects(subject, prop)}


def test_the_kinect_has_an_rgb_and_a_depth_optical_frame_and_its_declared_field_of_view(graph):
    frames = {graph.value(f, CORE.hasLink): _type(graph, f) for f in graph.objects(R.comp_kinect, CORE.hasOpticalFrame)}
    assert sorted(frames.values()) == [CORE.DepthFrame, CORE.RgbFrame]
    assert float(graph.value(R.comp_kinect, CORE.horizontalFieldOfViewRadians)) == pytest.approx(math.radians(57), abs=1e-4)
    assert _names(graph, R.comp_kinect, CORE.hasReferenceFrame) == {  # each imager's plugin frameName
        "head_mount_kinect_rgb_optical_frame", "head_mount_kinect_ir_optical_frame"}


def test_each_camera_says_from_how_many_places_it_sees(graph):
    counts = {str(graph.value(c, RDFS.label)): int(graph.value(c, CORE.viewpointCount))
              for c in graph.subjects(CORE.viewpointCount, None)}
    assert counts == {"kinect": 2, "wide_stereo": 2, "prosilica": 1, "r_forearm_cam": 1, "l_forearm_cam": 1}


@pytest.mark.parametrize("side", ["l", "r"])
def test_each_forearm_camera_has_a_reference_frame_and_an_image_size(graph, side):
    camera = R[f"comp_{side}_forearm_cam"]
    assert _names(graph, camera, CORE.hasReferenceFrame) == {f"{side}_forearm_cam_optical_frame"}
    assert (int(graph.value(camera, CORE.imageWidthPixels)), int(graph.value(camera, CORE.imageHeightPixels))) == (640, 480)
    [frequency] = [p for cap in graph.objects(camera, SSN_SYSTEM.hasSystemCapability)
                   for p in graph.objects(cap, SSN_SYSTEM.hasSystemProperty) if (p, RDF.type, SSN_SYSTEM.Frequency) in graph]
    assert (float(graph.value(frequency, SCHEMA.value)), str(graph.value(frequency, SCHEMA.unitCode))) == (25.0, "HTZ")


def test_the_base_laser_states_its_range_and_resolution_the_imu_nothing(graph):
    [cap] = graph.objects(R.comp_base_laser, SSN_SYSTEM.hasSystemCapability)
    kinds = {_type(graph, p): p for p in graph.objects(cap, SSN_SYSTEM.hasSystemProperty)}
    span = kinds[SSN_SYSTEM.MeasurementRange]
    assert (float(graph.value(span, SCHEMA.minValue)), float(graph.value(span, SCHEMA.maxValue))) == (0.08, 10.0)
    assert float(graph.value(kinds[SSN_SYSTEM.Resolution], SCHEMA.value)) == 0.01
    assert int(graph.value(R.comp_base_laser, CORE.raySamples)) == 640
    assert not list(graph.objects(R.comp_imu, SSN_SYSTEM.hasSystemCapability))  # PR2 declares no IMU sensor


def independent_reach(urdf: Path, side: str) -> float:
    """yourdfpy's forward kinematics and scipy's bounded optimiser (L-BFGS-B from four seeded random starts):
    the largest distance from the shoulder pan joint (its child link's origin) to the gripper's tool frame."""
    minimize = pytest.importorskip("scipy.optimize").minimize
    robot = yourdfpy.URDF.load(str(urdf), load_meshes=False, build_collision_scene_graph=False,
                               load_collision_meshes=False)
    joints = [f"{side}_{j}_joint" for j in PR2_ARM]
    bounds = [(-math.pi, math.pi) if robot.joint_map[j].type == "continuous"
              else (robot.joint_map[j].limit.lower, robot.joint_map[j].limit.upper) for j in joints]

    def distance(q) -> float:
        robot.update_cfg(dict(zip(joints, q)))
        return float(np.linalg.norm(robot.get_transform(f"{side}_gripper_tool_frame", f"{side}_shoulder_pan_link")[:3, 3]))

    rng = np.random.default_rng(7)
    starts = [[lo + rng.random() * (hi - lo) for lo, hi in bounds] for _ in range(4)]
    return max(-minimize(lambda q: -distance(q), x0, method="L-BFGS-B", bounds=bounds).fun for x0 in starts)


@pytest.mark.parametrize("side", ["l", "r"])
def test_each_arm_has_seven_degrees_of_freedom_and_reaches_as_far_as_an_independent_computation(graph, pr2_urdf, side):
    arm = R[f"body_{side}_arm"]
    assert int(graph.value(arm, CORE.degreesOfFreedom)) == 7
    reach = float(graph.value(arm, CORE.reachMetres))
    assert reach == pytest.approx(independent_reach(pr2_urdf, side), rel=0.05)


def independent_opening(urdf: Path, side: str) -> float:
    """yourdfpy: how far the fingertip links move apart as the finger joint goes from its lower to its upper
    limit (the other finger joints follow it through <mimic>)."""
    robot = yourdfpy.URDF.load(str(urdf), load_meshes=False, build_collision_scene_graph=False, load_collision_meshes=False)
    drive = robot.joint_map[f"{side}_gripper_l_finger_joint"]

    def gap(q: float) -> float:
        robot.update_cfg({drive.name: q})
        tips = [robot.get_transform(f"{side}_gripper_{f}_finger_tip_link", f"{side}_gripper_palm_link")[:3, 3] for f in "lr"]
        return float(np.linalg.norm(tips[0] - tips[1]))

    return gap(drive.limit.upper) - gap(drive.limit.lower)


@pytest.mark.parametrize("side", ["l", "r"])
def test_each_grippers_opening_comes_from_its_finger_joint_limits(graph, pr2_urdf, tmp_path, side):
    opening = float(graph.value(R[f"comp_{side}_gripper"], CORE.maxOpeningMetres))
    assert opening == pytest.approx(independent_opening(pr2_urdf, side), abs=1e-4)
    narrower = tmp_path / "pr2.urdf"  # the finger joint (and those that follow it) limited to half its stroke
    narrower.write_text(pr2_urdf.read_text().replace('upper="0.548"', 'upper="0.274"'))
    tree = load_urdf(narrower)
    gripper = next(c for c in PR2_WHOLE.components if c.name == f"{side}_gripper")
    assert capabilities.opening(tree, gripper.links) == pytest.approx(independent_opening(narrower, side), abs=1e-4)
    narrowed = capabilities.opening(tree, gripper.links)
    assert narrowed is not None and narrowed < opening - 0.03


def test_the_heads_pan_and_tilt_ranges(graph):
    assert float(graph.value(R.body_head, CORE.panRangeRadians)) == pytest.approx(3.007 * 2)
    assert float(graph.value(R.body_head, CORE.tiltRangeRadians)) == pytest.approx(0.471238 + 1.39626, abs=1e-4)


def test_a_robot_without_body_or_declarations_gets_no_capability(pr2_tree):
    bare = KinematicTree(pr2_tree.robot_name, pr2_tree.links, pr2_tree.edges)  # no evidence: nothing declared
    onto = build_robot(owlready2.World(), bare, "pr2", Abstraction(PR2.components[:1]))  # the kinect
    from urdfkb.pipeline.knowledge.export import robot_graph
    g = robot_graph(onto)
    kinect = rdflib.URIRef(onto.base_iri + "comp_kinect")
    assert not list(g.objects(kinect, CORE.horizontalFieldOfViewRadians)) and not list(g.subjects(CORE.reachMetres, None))
    assert {str(g.value(f, CORE.urdfName)) for f in g.objects(kinect, CORE.hasReferenceFrame)} == {  # its optical frames
        "head_mount_kinect_rgb_optical_frame", "head_mount_kinect_ir_optical_frame"}


@pytest.mark.reasoner
def test_the_populated_export_is_consistent_and_in_owl2_dl(pr2, tmp_path):
    """HermiT finds the populated PR2 consistent, and the OWL API (HermiT's own, Protégé's) reads the export
    offline and finds it within the OWL 2 DL profile."""
    from urdfkb.pipeline.knowledge.export import export_robot
    path = tmp_path / "pr2.owl"
    export_robot(pr2, path)
    world = owlready2.World()
    with open(path, "rb") as f:
        world.get_ontology(pr2.base_iri[:-1]).load(fileobj=f)
    owlready2.sync_reasoner(world, infer_property_values=False, debug=0)
    assert list(world.inconsistent_classes()) == []
    run = subprocess.run([owlready2.JAVA_EXE, "-cp", owlready2.reasoning._HERMIT_CLASSPATH, str(DL_CHECK), str(path)],
                         capture_output=True, text=True, timeout=300)
    assert run.returncode == 0 and run.stdout.strip().endswith("IN PROFILE") and "NOT IN" not in run.stdout, run.stdout + run.stderr


@pytest.mark.reasoner
def test_hermit_finds_a_monocular_camera_that_sees_from_two_places_inconsistent(pr2_tree):
    """The viewpoint count population asserts lets the reasoner check core:viewpointCount's definitions: PR2's
    stereo pair written as a monocular camera (at most one place) cannot be."""
    wrong = replace(PR2_WHOLE, components=tuple(replace(c, cls="MonocularCamera") if c.name == "wide_stereo" else c
                                                 for c in PR2_WHOLE.components))
    world = owlready2.World()
    build_robot(world, pr2_tree, "pr2", wrong)
    with pytest.raises(owlready2.OwlReadyInconsistentOntologyError):
        owlready2.sync_reasoner(world, infer_property_values=False, debug=0)


@pytest.mark.reasoner
def test_what_a_ranging_sensor_emits_is_stored_and_checked_by_the_reasoner():
    """Population writes core:rangingRadiation as the range plugin states it; HermiT finds the populated robot
    consistent, and the same sensor typed a sonar inconsistent (a sonar emits ultrasound)."""
    from tests.test_evidence import _range_plugins
    from urdfkb.pipeline.knowledge.export import robot_graph
    from urdfkb.pipeline.llm.scripted import ScriptedBackend
    from urdfkb.pipeline.runner import Settings, run
    urdf, _ = _range_plugins(3, [("infrared", 0.3, None)])
    tree = load_urdf(urdf)
    found = run(tree, Settings(use_cache=False), backend=ScriptedBackend(lambda q: q.options[0]))
    [ranger] = [c for c in found.components if c.kind == SENSOR]
    assert ranger.cls == "RangingSensor"
    world = owlready2.World()
    robot = build_robot(world, tree, "floor", found)
    graph = robot_graph(robot)
    [ind] = graph.subjects(CORE.rangingRadiation, None)
    assert str(graph.value(ind, CORE.rangingRadiation)) == "infrared"
    owlready2.sync_reasoner(world, infer_property_values=False, debug=0)
    wrong = owlready2.World()
    build_robot(wrong, tree, "floor", replace(found, components=tuple(replace(c, cls="Sonar") if c is ranger else c
                                                                      for c in found.components)))
    sonar = next(wrong.sparql("SELECT ?s WHERE { ?s a <%sSonar> }" % CORE))[0]
    wrong[str(CORE.rangingRadiation)][sonar].append("infrared")  # what population leaves out for a sonar
    with pytest.raises(owlready2.OwlReadyInconsistentOntologyError):
        owlready2.sync_reasoner(wrong, infer_property_values=False, debug=0)


def test_population_finds_where_each_capability_goes_in_the_ontology():
    assert (TAX.domain("reachMetres"), TAX.domain("panRangeRadians"), TAX.domain("maxOpeningMetres")) == ("Arm", "Head", "Gripper")
    assert (TAX.domain("hasOpticalFrame"), TAX.range("hasOpticalFrame")) == ("Camera", "OpticalFrame")
    with pytest.raises(OntologyError, match="urdfName"):
        TAX.domain("urdfName")  # Robot, Link or Joint: no one named class
