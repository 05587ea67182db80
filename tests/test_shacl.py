"""The shapes accept a well-populated robot (every truth robot, populated) and name what is wrong with a broken one."""
import hashlib

import owlready2
import pytest
import rdflib
from rdflib.namespace import PROV, RDF

from tests.sample_bot import sample_abstraction, sample_tree
from tests.scripted_reasoner import scripted_placements, scripted_reasoner
from urdfkb.pipeline.scoring.truth import load_truth
from urdfkb.pipeline.abstraction.components import Abstraction, Component
from urdfkb.pipeline.knowledge.export import robot_graph
from urdfkb.pipeline.reading.ingest import load_urdf
from urdfkb.pipeline.llm.scripted import ScriptedBackend
from urdfkb.pipeline.knowledge.namespaces import CORE_IRI
from urdfkb.pipeline.knowledge.population import build_robot
from urdfkb.pipeline.runner import Settings, run
from urdfkb.pipeline.knowledge.shacl import validate, violations

CORE = rdflib.Namespace(CORE_IRI)


def populated(abstraction=None):
    onto = build_robot(owlready2.World(), sample_tree(), "bot", abstraction or sample_abstraction())
    return robot_graph(onto)


def node(g, cls):
    return next(g.subjects(RDF.type, CORE[cls]))


def link(g, name):
    return next(g.subjects(CORE.urdfName, rdflib.Literal(name, datatype=rdflib.XSD.string)))


def test_populated_robot_conforms():
    conforms, report = validate(populated())
    assert conforms, report


def test_structure_only_robot_conforms():
    conforms, report = validate(robot_graph(build_robot(owlready2.World(), sample_tree(), "bot")))
    assert conforms, report


def test_data_graph_is_not_modified():
    g = populated()
    size = len(g)
    validate(g)
    assert len(g) == size


def breaks(edit):
    g = populated()
    edit(g)
    conforms, report = validate(g)
    assert not conforms
    return report


def lines(edit) -> list[str]:
    """The violations of the sample robot once `edit`ed, one line each."""
    g = populated()
    edit(g)
    return violations(g)


def test_camera_without_optical_frame():
    """Targets reach subclasses: the RGBDCamera is a Camera through the core's subClassOf triples (no inference)."""
    def edit(g):
        for s in set(g.subjects(RDF.type, CORE.DepthFrame)) | set(g.subjects(RDF.type, CORE.RgbFrame)):
            g.remove((s, RDF.type, None))
            g.add((s, RDF.type, CORE.SensingElement))
    assert "OpticalFrame" in breaks(edit)


def test_camera_component_typed_without_optical_frame_from_population():
    abstraction = sample_abstraction(camera_cls="StereoCamera", rgb_cls="SensorHousing")
    camera = abstraction.components[0]
    only_housing = Component(camera.name, camera.kind, camera.cls, camera.confidence, camera.root,
                             camera.subcomponents[:1])
    conforms, report = validate(populated(Abstraction((only_housing,))))
    assert not conforms and "OpticalFrame" in report


def test_camera_needs_its_optical_frames_named_and_one_of_a_modality():
    def unnamed(g):
        g.remove((None, CORE.hasOpticalFrame, None))
    assert "CameraShape: comp_head%20camera hasOpticalFrame: a camera needs at least one optical frame " \
        "(hasOpticalFrame)" in lines(unnamed)

    def no_modality(g):
        for s in set(g.subjects(RDF.type, CORE.DepthFrame)) | set(g.subjects(RDF.type, CORE.RgbFrame)):
            g.remove((s, RDF.type, None))
            g.add((s, RDF.type, CORE.OpticalFrame))
    assert lines(no_modality) == ["ModalityShape: comp_head%20camera: a camera needs an optical frame of a modality: "
                                  "RGB, depth or infrared"]


def test_a_camera_a_reviewer_wrote_needs_no_modality():
    """A reviewer names a device's class and links (prov:wasInfluencedBy a correction), not each frame's image."""
    g = populated(sample_abstraction(rgb_cls="OpticalFrame"))
    (depth,) = g.subjects(RDF.type, CORE.DepthFrame)
    g.set((depth, RDF.type, CORE.OpticalFrame))
    assert violations(g)  # its frames have no modality
    g.add((node(g, "RGBDCamera"), PROV.wasInfluencedBy, rdflib.URIRef("https://example.org/correction")))
    conforms, report = validate(g)
    assert conforms, report


def test_sensor_needs_a_reference_frame():
    assert lines(lambda g: g.remove((None, CORE.hasReferenceFrame, None))) == [
        "ReferenceFrameShape: comp_head%20camera hasReferenceFrame: a sensor needs a reference frame "
        "(hasReferenceFrame): the link its measurements are expressed in"]


def test_component_with_two_mounts():
    report = breaks(lambda g: g.add((node(g, "ParallelGripper"), CORE.isMountedOn, link(g, "base_link"))))
    assert "isMountedOn" in report


def test_component_without_mount():
    assert "isMountedOn" in breaks(lambda g: g.remove((node(g, "ParallelGripper"), CORE.isMountedOn, None)))


def test_component_not_reached_from_a_robot():
    def edit(g):
        g.remove((None, CORE.hasComponent, node(g, "ParallelGripper")))
    assert "hasComponent" in breaks(edit)


def test_subpart_with_two_links_or_none():
    assert "hasLink" in breaks(lambda g: g.add((node(g, "Finger"), CORE.hasLink, link(g, "base_link"))))
    assert "hasLink" in breaks(lambda g: g.remove((node(g, "Finger"), CORE.hasLink, None)))


@pytest.mark.parametrize("value", [rdflib.Literal("1.5", datatype=rdflib.XSD.decimal),
                                   rdflib.Literal("-0.1", datatype=rdflib.XSD.decimal),
                                   rdflib.Literal("0.5", datatype=rdflib.XSD.double),
                                   rdflib.Literal("high")])
def test_bad_confidence(value):
    def edit(g):
        finger = node(g, "Finger")
        g.remove((finger, CORE.confidence, None))
        g.add((finger, CORE.confidence, value))
    assert "confidence" in breaks(edit)


def test_link_needs_exactly_one_urdf_name():
    assert "urdfName" in breaks(lambda g: g.add((node(g, "Link"), CORE.urdfName, rdflib.Literal("alias"))))
    assert "urdfName" in breaks(lambda g: g.remove((node(g, "Link"), CORE.urdfName, None)))


def test_joint_needs_one_parent_and_one_child():
    report = breaks(lambda g: g.add((node(g, "RevoluteJoint"), CORE.hasParentLink, link(g, "tool_frame"))))
    assert "hasParentLink" in report
    assert "hasChildLink" in breaks(lambda g: g.remove((node(g, "FixedJoint"), CORE.hasChildLink, None)))


def test_mount_on_something_without_urdf_name():
    """A mount must be a Link of the robot (sh:class): an IRI typed nothing is reported."""
    dangling = rdflib.URIRef("https://example.org/nowhere")

    def edit(g):
        gripper = node(g, "ParallelGripper")
        g.remove((gripper, CORE.isMountedOn, None))
        g.add((gripper, CORE.isMountedOn, dangling))
    assert "nowhere" in breaks(edit)


@pytest.mark.parametrize("prop, value", [
    ("generatedAt", None), ("generatedAt", rdflib.Literal("yesterday")), ("softwareVersion", None),
    ("urdfSha256", rdflib.Literal("not a digest")), ("votingMode", rdflib.Literal("majority")),
])
def test_robot_provenance_is_required_and_well_formed(prop, value):
    def edit(g):
        robot = node(g, "Robot")
        g.remove((robot, CORE[prop], None))
        if value is not None:
            g.add((robot, CORE[prop], value))
    assert prop in breaks(edit)


@pytest.mark.slow
def test_shared_urdfs_conform_structure_only(shared):
    world = owlready2.World()
    paths = sorted((shared / "urdf").glob("*.urdf"))
    assert paths, "no shared URDF"
    for path in paths:
        tree = load_urdf(path)
        conforms, report = validate(robot_graph(build_robot(world, tree, tree.robot_name)))
        assert conforms, f"{path.name}: {report}"


@pytest.mark.slow
def test_shared_truth_robots_populated_conform_with_nothing_held(shared):
    """Every truth robot through the pipeline, a model answering by a hash of each question (another robot
    each time, as the transcript benchmark's): nothing breaks the shapes, so nothing is held back by them (the
    gates before them, a sensor under the floor or a tool with no body, hold what they hold)."""
    def hashed(q):
        return q.options[int(hashlib.sha256((q.system + q.user).encode()).hexdigest(), 16) % len(q.options)]
    paths = sorted((shared / "eval" / "truth").glob("*.yaml"))
    assert paths, "no truth robot"
    for path in paths:
        tree = load_urdf(shared / load_truth(path).urdf)
        abstraction = run(tree, Settings(use_cache=False), backend=ScriptedBackend(hashed), reasoner=scripted_reasoner,
                          placer=scripted_placements)
        broke = [h for h in abstraction.held if not h.violations[0].startswith(("SensorFloor", "BodilessTool"))]
        assert broke == [], f"{path.stem}: {broke}"
        conforms, report = validate(robot_graph(build_robot(owlready2.World(), tree, tree.robot_name, abstraction)))
        assert conforms, f"{path.stem}: {report}"
