"""Exported robots are self-contained, round-trip in every format and reload in a fresh owlready2 World."""
import io
import os
import subprocess

import owlready2
import owlready2.reasoning
import pytest
import rdflib
from rdflib.compare import isomorphic
from rdflib.namespace import OWL, RDF, RDFS

from urdfkb.pipeline.errors import OntologyError
from urdfkb.pipeline.knowledge.export import export_robot, robot_graph
from urdfkb.pipeline.knowledge.formats import BY_NAME
from urdfkb.pipeline.knowledge.namespaces import CORE_IRI
from urdfkb.pipeline.knowledge.population import build_robot
from urdfkb.pipeline.reading.tree import Edge, KinematicTree
from tests.sample_bot import HOSTILE, ZERO, sample_abstraction, sample_tree

CORE = rdflib.Namespace(CORE_IRI)
PARSERS = {"rdfxml": "xml", "turtle": "turtle", "ntriples": "nt"}


@pytest.fixture(scope="module")
def onto():
    return build_robot(owlready2.World(), sample_tree(), "bot", sample_abstraction())


@pytest.fixture(scope="module")
def hostile_onto():
    links = ("root", *HOSTILE)
    tree = KinematicTree('robot "#/%', links, tuple(Edge(f"j {n}", "fixed", "root", n, ZERO) for n in HOSTILE))
    return build_robot(owlready2.World(), tree, tree.robot_name)


def test_graph_is_self_contained(onto):
    g = robot_graph(onto)
    assert not list(g.triples((None, OWL.imports, None)))
    assert list(g.subjects(RDF.type, OWL.Ontology)) == [rdflib.URIRef(onto.base_iri[:-1])]
    assert (CORE.RGBDCamera, RDFS.subClassOf, CORE.Camera) in g
    assert (CORE.RgbFrame, RDFS.comment, None) in g
    assert len(list(g.subjects(RDF.type, CORE.Link))) == 10


@pytest.mark.slow
@pytest.mark.parametrize("fmt", BY_NAME)
def test_round_trip_through_a_file(onto, hostile_onto, tmp_path, fmt):
    for robot in (onto, hostile_onto):
        path = tmp_path / f"robot.{fmt}"
        export_robot(robot, path, fmt)
        back = rdflib.Graph().parse(path, format=PARSERS[fmt])
        assert isomorphic(back, robot_graph(robot))
    assert os.listdir(tmp_path) == [f"robot.{fmt}"]


@pytest.mark.slow  # over a second of its own (make test-fast leaves it out)
def test_stream_destination(onto):
    buf = io.BytesIO()
    export_robot(onto, buf, "turtle")
    assert isomorphic(rdflib.Graph().parse(data=buf.getvalue(), format="turtle"), robot_graph(onto))


@pytest.mark.reasoner
def test_rdfxml_reloads_in_a_fresh_world(hostile_onto, tmp_path):
    path = tmp_path / "robot.owl"
    export_robot(hostile_onto, str(path))
    world = owlready2.World()
    with open(path, "rb") as f:
        loaded = world.get_ontology(hostile_onto.base_iri[:-1]).load(fileobj=f)
    names = {i.urdfName for i in world.search(type=world[CORE_IRI + "Link"])}
    assert names == {"root", *HOSTILE}
    assert len(list(loaded.individuals())) == 2 * len(HOSTILE) + 2
    owlready2.sync_reasoner(world, infer_property_values=False, debug=0)


@pytest.mark.reasoner
def test_populated_export_reloads_and_is_consistent(onto, tmp_path):
    path = tmp_path / "bot.owl"
    export_robot(onto, path)
    world = owlready2.World()
    with open(path, "rb") as f:
        world.get_ontology(onto.base_iri[:-1]).load(fileobj=f)
    [camera] = world.search(type=world[CORE_IRI + "Camera"])
    assert camera.isMountedOn.urdfName == "head_link" and float(camera.confidence) == 0.93
    owlready2.sync_reasoner(world, infer_property_values=False, debug=0)
    assert list(world.inconsistent_classes()) == []


def test_overwrites_atomically_and_refuses_unknown_format(onto, tmp_path):
    path = tmp_path / "bot.ttl"
    path.write_text("old")
    export_robot(onto, path, "turtle")
    assert path.read_text(encoding="utf-8").startswith("@prefix")
    with pytest.raises(OntologyError, match="jsonld"):
        export_robot(onto, tmp_path / "x.jsonld", "jsonld")
    assert sorted(os.listdir(tmp_path)) == ["bot.ttl"]


@pytest.mark.reasoner
def test_owlapi_opens_the_file_offline(onto, hostile_onto, tmp_path):
    """HermiT's own OWL API parser (Protégé's) reads the RDF/XML file alone: no import to resolve."""
    for robot in (onto, hostile_onto):
        path = tmp_path / "robot.owl"
        export_robot(robot, path)
        run = subprocess.run([owlready2.JAVA_EXE, "-cp", owlready2.reasoning._HERMIT_CLASSPATH,
                              "org.semanticweb.HermiT.cli.CommandLine", "-k", path.as_uri()],
                             capture_output=True, text=True, timeout=300)
        assert run.returncode == 0 and "owl#Thing is satisfiable" in run.stdout, run.stderr
