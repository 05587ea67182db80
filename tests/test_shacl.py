"""The shapes accept a well-populated robot and name what is wrong with a broken one."""
import owlready2
import pytest
import rdflib
from rdflib.namespace import RDF

from urdfkb.pipeline.components import Abstraction, Component
from urdfkb.pipeline.export import robot_graph
from urdfkb.pipeline.ingest import load_urdf
from urdfkb.pipeline.ontology import CORE_IRI
from urdfkb.pipeline.population import build_robot
from urdfkb.pipeline.shacl import validate
from tests.sample_bot import sample_abstraction, sample_tree

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
