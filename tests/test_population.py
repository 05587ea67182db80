"""Populating robots: structure, components, safe IRIs, isolation between robots, refusal of bad input."""
import io
import re
from datetime import datetime, timezone

import owlready2
import pytest
import rdflib

from tests.sample_bot import HOSTILE, ZERO, sample_abstraction, sample_tree
from urdfkb.pipeline.abstraction.components import Abstraction, Component, SubComponent
from urdfkb.pipeline.errors import OntologyError
from urdfkb.pipeline.reading.ingest import load_urdf
from urdfkb.pipeline.knowledge.namespaces import CORE_IRI, escape, robot_iri
from urdfkb.pipeline.knowledge.ontology import vocabulary
from urdfkb.pipeline.knowledge.population import build_robot
from urdfkb.pipeline.reading.tree import Edge, KinematicTree

CORE = rdflib.Namespace(CORE_IRI)
IRI_CHARS = re.compile(r"[A-Za-z0-9:/._~%#-]+")


def triples(onto):
    buf = io.BytesIO()
    onto.save(buf, format="ntriples")
    return rdflib.Graph().parse(data=buf.getvalue(), format="nt")


def named(graph, name):
    [node] = graph.subjects(CORE.urdfName, rdflib.Literal(name, datatype=rdflib.XSD.string))
    return node


def test_structure():
    world = owlready2.World()
    onto = build_robot(world, sample_tree(), "bot")
    g = triples(onto)
    [robot] = g.subjects(rdflib.RDF.type, CORE.Robot)
    assert len(list(g.objects(robot, CORE.hasLink))) == 10
    assert len(list(g.objects(robot, CORE.hasJoint))) == 9
    joint = named(g, "head_joint")
    assert (joint, rdflib.RDF.type, CORE.RevoluteJoint) in g
    assert g.value(joint, CORE.hasParentLink) == named(g, "base_link")
    assert g.value(joint, CORE.hasChildLink) == named(g, "head_link")
    types = {t for j in g.objects(robot, CORE.hasJoint) for t in g.objects(j, rdflib.RDF.type)}
    assert {CORE[t] for t in ("FixedJoint", "RevoluteJoint", "ContinuousJoint", "PrismaticJoint",
                               "FloatingJoint", "PlanarJoint")} <= types
    assert not list(g.triples((None, CORE.hasComponent, None)))
    assert str(g.value(robot, CORE.ontologyVersion)) == vocabulary().version


def test_components_and_provenance():
    world = owlready2.World()
    onto = build_robot(world, sample_tree(), "bot", sample_abstraction(), {"generatedAt": "2026-11-21T09:00:00+00:00"})
    g = triples(onto)
    [robot] = g.subjects(rdflib.RDF.type, CORE.Robot)
    comps = {str(g.value(c, rdflib.RDFS.label)): c for c in g.objects(robot, CORE.hasComponent)}
    assert comps.keys() == {"head camera", "gripper"}
    cam = comps["head camera"]
    assert (cam, rdflib.RDF.type, CORE.RGBDCamera) in g
    assert g.value(cam, CORE.isMountedOn) == named(g, "head_link")
    conf = g.value(comps["gripper"], CORE.confidence)
    assert conf.datatype == rdflib.XSD.decimal and float(conf) == 0.6667
    subs = list(g.objects(cam, CORE.hasComponent))
    links = {g.value(s, CORE.hasLink): s for s in subs}
    rgb = links[named(g, "cam_rgb_optical_frame")]
    assert (rgb, rdflib.RDF.type, CORE.RgbFrame) in g and float(g.value(rgb, CORE.confidence)) == 0.8
    assert len(subs) == 2 and len(list(g.objects(comps["gripper"], CORE.hasComponent))) == 2
    assert str(g.value(robot, CORE.abstractionModel)) == "tiny-q4"
    assert str(g.value(robot, CORE.votesPerQuestion)) == "3"
    at = g.value(robot, CORE.generatedAt)
    assert at.datatype == rdflib.XSD.dateTime and at.toPython() == datetime(2026, 11, 21, 9, tzinfo=timezone.utc)
    assert str(g.value(robot, CORE.provenanceNote)) == "favourite colour=blue"


@pytest.mark.reasoner
def test_populated_robot_is_consistent_for_hermit():
    world = owlready2.World()
    build_robot(world, sample_tree(), "bot", sample_abstraction())
    owlready2.sync_reasoner(world, infer_property_values=False, debug=0)
    assert list(world.inconsistent_classes()) == []


@pytest.mark.parametrize("name", HOSTILE)
def test_hostile_names_give_valid_distinct_iris(name):
    links = ("base_link", "caster_link", "odom_link", name, "cam_link", "cam_rgb_optical_frame",
             "cam_depth_optical_frame", "wrist_link", "finger_link", "tool_frame")
    tree = KinematicTree(name, links, (Edge(name, "fixed", "base_link", name, ZERO),
                                       Edge("j2", "revolute", "base_link", "caster_link", ZERO),
                                       *(Edge(f"j{c}", "fixed", "base_link", c, ZERO) for c in links[2:] if c != name)))
    world = owlready2.World()
    g = triples(build_robot(world, tree, name))
    link, joint = (s for s in g.subjects(CORE.urdfName, rdflib.Literal(name, datatype=rdflib.XSD.string))
                   if (s, rdflib.RDF.type, CORE.Robot) not in g)
    assert link != joint
    for node in (link, joint, rdflib.URIRef(robot_iri(name))):
        assert IRI_CHARS.fullmatch(str(node)), node
    assert str(link).startswith(robot_iri(name))


def test_escape_is_injective_and_plain_for_ordinary_names():
    escaped = [escape(n) for n in HOSTILE]
    assert len(set(escaped)) == len(HOSTILE)
    assert escape("base_link-2~") == "base_link-2~"
    assert escape("a.b") == "a%2Eb" and escape("a%2Eb") == "a%252Eb"


def test_names_that_escape_alike_do_not_collide():
    """A sub-link IRI joins component and link with '.', which escape() never emits."""
    links = ("r", "a", "a.b", "b.c", "c")
    tree = KinematicTree("t", links, tuple(Edge(f"j{link}", "fixed", "r", link, ZERO) for link in links[1:]))
    comps = (Component("a.b", "sensor", "IMU", 1, "r", (SubComponent("c", "SensingElement", 1),)),
             Component("a", "sensor", "IMU", 1, "r", (SubComponent("b.c", "SensingElement", 1),)))
    g = triples(build_robot(owlready2.World(), tree, "t", Abstraction(comps)))
    assert len(set(g.subjects(rdflib.RDF.type, CORE.SensingElement))) == 2
    assert len(set(g.subjects(rdflib.RDF.type, CORE.IMU))) == 2


def test_two_robots_in_one_world_share_no_individual():
    world = owlready2.World()
    one = build_robot(world, sample_tree("one"), "one", sample_abstraction())
    two = build_robot(world, sample_tree("two"), "two", sample_abstraction())
    assert one.base_iri != two.base_iri
    ones, twos = set(triples(one).subjects()), set(triples(two).subjects())
    assert len(ones) > 20 and not ({s for s in ones if "/robot/" in s} & twos)
    assert all(str(i.iri).startswith(one.base_iri) for i in one.individuals())


def test_rebuilding_a_robot_replaces_it():
    world = owlready2.World()
    build_robot(world, sample_tree(), "bot", sample_abstraction())
    onto = build_robot(world, sample_tree(), "bot")
    assert not list(triples(onto).triples((None, CORE.hasComponent, None)))
    assert world.search(type=world[CORE_IRI + "RGBDCamera"]) == []


def _with_bad_sub(comp, link):
    return Component(comp.name, comp.kind, comp.cls, comp.confidence, comp.root,
                     (*comp.subcomponents, SubComponent(link, "SensingElement", 1)))


BAD = {
    "unknown sub-link": lambda a: Abstraction((_with_bad_sub(a.components[0], "nope_link"),)),
    "unknown root": lambda a: Abstraction((Component("c", "sensor", "IMU", 1, "nope_root", ()),)),
    "class outside Sensor": lambda a: Abstraction((Component("c", "sensor", "Gripper", 1, "head_link", ()),)),
    "structural class": lambda a: Abstraction((Component("c", "sensor", "Link", 1, "head_link", ()),)),
    "unknown class": lambda a: Abstraction((Component("c", "sensor", "Telescope", 1, "head_link", ()),)),
    "subpart class": lambda a: Abstraction((Component("c", "sensor", "IMU", 1, "head_link",
                                                      (SubComponent("cam_link", "Camera", 1),)),)),
    "unknown kind": lambda a: Abstraction((Component("c", "body", "IMU", 1, "head_link", ()),)),
    "confidence above 1": lambda a: Abstraction((Component("c", "sensor", "IMU", 1.5, "head_link", ()),)),
    "confidence NaN": lambda a: Abstraction((Component("c", "sensor", "IMU", 1, "head_link",
                                                       (SubComponent("cam_link", "SensingElement", float("nan")),)),)),
    "duplicate component": lambda a: Abstraction((a.components[1], a.components[1])),
    "duplicate sub-link": lambda a: Abstraction((Component("c", "sensor", "IMU", 1, "head_link",
                                                           (SubComponent("cam_link", "SensingElement", 1),) * 2),)),
}


@pytest.mark.parametrize("case", BAD)
def test_bad_abstraction_writes_nothing(case):
    world = owlready2.World()
    build_robot(world, sample_tree(), "bot", sample_abstraction())
    before = len(world.graph)
    with pytest.raises(OntologyError):
        build_robot(world, sample_tree(), "bot", BAD[case](sample_abstraction()))
    with pytest.raises(OntologyError):
        build_robot(world, sample_tree(), "other", BAD[case](sample_abstraction()))
    assert len(world.graph) == before
    assert robot_iri("other") not in world.ontologies


def test_bad_link_is_named():
    with pytest.raises(OntologyError, match="nope_link"):
        build_robot(owlready2.World(), sample_tree(), "bot", BAD["unknown sub-link"](sample_abstraction()))


def test_sqlite_world_holds_several_robots(tmp_path):
    path = str(tmp_path / "kb.sqlite3")
    world = owlready2.World(filename=path)
    build_robot(world, sample_tree("one"), "one", sample_abstraction())
    build_robot(world, sample_tree("two"), "two")
    world.save()
    size = len(world.graph)
    world.close()
    world = owlready2.World(filename=path)
    assert len(world.graph) == size
    onto = world.get_ontology(robot_iri("one"))
    assert len(triples(onto)) > 100
    build_robot(world, sample_tree("one"), "one", sample_abstraction())
    assert len(world.graph) == size
    world.close()


def test_empty_robot_name_is_refused():
    with pytest.raises(OntologyError):
        robot_iri("")


@pytest.mark.reasoner
def test_shared_urdfs_populate_exactly_and_consistently(shared):
    world = owlready2.World()
    paths = sorted((shared / "urdf").glob("*.urdf"))
    assert paths, "no shared URDF"
    for path in paths:
        tree = load_urdf(path)
        g = triples(build_robot(world, tree, tree.robot_name))
        names = {str(n) for link in g.subjects(rdflib.RDF.type, CORE.Link) for n in g.objects(link, CORE.urdfName)}
        assert names == set(tree.links), path.name
    owlready2.sync_reasoner(world, infer_property_values=False, debug=0)
    assert list(world.inconsistent_classes()) == []


@pytest.mark.reasoner
def test_joint_facts_body_parts_and_locations():
    """Limits, axis and mimic on every joint; body parts under the robot (a wheel under the base), with their
    joints, links, mount and side; a device located on the part carrying its mount, with its own joints."""
    urdf = (b'<robot name="j"><link name="base"/><link name="wheel"/><link name="upper"/><link name="hand"/>'
            b'<link name="jaw"/><link name="jaw2"/>'
            b'<joint name="roll" type="continuous"><parent link="base"/><child link="wheel"/><axis xyz="0 1 0"/></joint>'
            b'<joint name="shoulder" type="revolute"><parent link="base"/><child link="upper"/><origin xyz="0 0.2 0"/>'
            b'<axis xyz="0 0 1"/><limit lower="-1.5" upper="2.25" velocity="3" effort="40"/></joint>'
            b'<joint name="wrist" type="fixed"><parent link="upper"/><child link="hand"/></joint>'
            b'<joint name="grip" type="prismatic"><parent link="hand"/><child link="jaw"/>'
            b'<limit lower="0" upper="0.04" velocity="0.1" effort="5"/></joint>'
            b'<joint name="grip2" type="prismatic"><parent link="hand"/><child link="jaw2"/><mimic joint="grip" multiplier="-1" offset="0.01"/>'
            b'<limit lower="-0.04" upper="0" velocity="0.1" effort="5"/></joint></robot>')
    tree = load_urdf(urdf)
    from urdfkb.pipeline.abstraction.components import BodyPart
    gripper = Component("g", "end_effector", "ParallelGripper", 1.0, "upper",
                        (SubComponent("hand", "Palm", 1.0), SubComponent("jaw", "Finger", 1.0), SubComponent("jaw2", "Finger", 1.0)),
                        joints=("grip", "grip2"), located_on="arm", side="left")
    body = (BodyPart("base", "MobileBase", 1.0, None, (), ("base",)),
            BodyPart("wheel", "Wheel", 1.0, "base", ("roll",), ("wheel",), parent="base"),
            BodyPart("arm", "Arm", 0.9, "base", ("shoulder",), ("upper",), side="left"))
    world = owlready2.World()
    g = triples(build_robot(world, tree, "j", Abstraction((gripper,), {}, body)))
    owlready2.sync_reasoner(world, infer_property_values=False, debug=0)  # the body's axioms hold: consistent
    assert list(world.inconsistent_classes()) == []
    shoulder, grip2 = named(g, "shoulder"), named(g, "grip2")
    facts = {p.split("#")[1]: float(o) for p, o in g.predicate_objects(shoulder)
             if isinstance(o, rdflib.Literal) and p.startswith(CORE_IRI) and p != CORE.urdfName}
    assert facts == {"lowerLimit": -1.5, "upperLimit": 2.25, "velocityLimit": 3.0, "effortLimit": 40.0,
                     "axisX": 0.0, "axisY": 0.0, "axisZ": 1.0}
    assert float(g.value(grip2, CORE.mimicMultiplier)) == -1 and float(g.value(grip2, CORE.mimicOffset)) == 0.01
    assert (grip2, CORE.isMimicOf, named(g, "grip")) in g
    robot = next(g.subjects(rdflib.RDF.type, CORE.Robot))
    [base] = g.subjects(rdflib.RDF.type, CORE.MobileBase)
    [wheel] = g.subjects(rdflib.RDF.type, CORE.Wheel)
    [arm] = g.subjects(rdflib.RDF.type, CORE.Arm)
    assert {(robot, CORE.hasComponent, base), (base, CORE.hasComponent, wheel), (robot, CORE.hasComponent, arm)} <= set(g)
    assert (wheel, CORE.hasJoint, named(g, "roll")) in g and (wheel, CORE.isMountedOn, named(g, "base")) in g
    assert str(g.value(arm, CORE.side)) == "left" and (arm, CORE.hasLink, named(g, "upper")) in g
    assert g.value(base, CORE.isMountedOn) is None and (base, CORE.hasLink, named(g, "base")) in g
    [comp] = g.subjects(rdflib.RDF.type, CORE.ParallelGripper)
    assert (comp, CORE.isLocatedOn, arm) in g and str(g.value(comp, CORE.side)) == "left"
    assert set(g.objects(comp, CORE.hasJoint)) == {named(g, "grip"), grip2}


@pytest.mark.parametrize("part,message", [
    (dict(cls="Sonar"), "not a BodyPart class"),
    (dict(joints=("nope",)), "names joint 'nope'"),
    (dict(side="up"), "side 'up'"),
    (dict(parent="ghost"), "unknown body part 'ghost'"),
])
def test_bad_body_parts_are_refused(part, message):
    from urdfkb.pipeline.abstraction.components import BodyPart
    body = (BodyPart(**{**dict(name="p", cls="Arm", confidence=1.0, root="base_link", joints=("head_joint",),
                               links=("head_link",)), **part}),)
    with pytest.raises(OntologyError, match=message):
        build_robot(owlready2.World(), sample_tree(), "t", Abstraction((), {}, body))
