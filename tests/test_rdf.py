"""The RDF seam (pipeline/knowledge/rdf.py): graphs leave and enter owlready2 as N-Triples unchanged, and the calls below
owlready2's object model write what they say."""
import pytest
import rdflib
from rdflib.compare import isomorphic
from rdflib.namespace import PROV

from urdfkb.pipeline.knowledge import rdf
from urdfkb.pipeline.knowledge.namespaces import CORE, CORE_IRI, robot_iri
from urdfkb.pipeline.knowledge.ontology import load_core
from urdfkb.pipeline.knowledge.population import build_robot
from tests.sample_bot import sample_abstraction, sample_tree


@pytest.fixture
def world():
    world = rdf.new_world()
    yield world
    world.close()


@pytest.fixture
def robot(world):
    return build_robot(world, sample_tree(), "bot", sample_abstraction())


def test_a_graph_leaves_and_enters_owlready2_unchanged(robot):
    data = rdf.ntriples(robot)
    graph = rdf.rdflib_graph(robot)
    assert len(graph) == len(data.splitlines()) > 50 and isomorphic(graph, rdf.parse_ntriples(data))
    other = rdf.new_world()
    try:
        copy = rdf.load_ntriples(other, robot.base_iri, data)
        assert isomorphic(rdf.rdflib_graph(copy), graph)
        assert isomorphic(rdf.rdflib_graph(rdf.load_graph(other, "urn:copy#", graph)), graph)
    finally:
        other.close()
    assert isomorphic(rdf.parse_ntriples(rdf.to_ntriples(graph)), graph)


def test_object_triples_by_iri_with_a_predicate_the_core_does_not_declare(robot):
    pairs = [(robot_iri("bot") + "comp_camera", "urn:review#correction_1"), (robot_iri("bot") + "link_base", "urn:review#c2")]
    rdf.add_object_triples(robot, str(PROV.wasInfluencedBy), pairs)
    graph = rdf.rdflib_graph(robot)
    assert {(str(s), str(o)) for s, o in graph.subject_objects(PROV.wasInfluencedBy)} == set(pairs)


def test_an_ontology_states_one_value_of_itself(world):
    onto = world.get_ontology("urn:test#")
    mark = CORE_IRI + "ontologyVersion"
    assert rdf.ontology_value(onto, "urn:never-used#mark") is None
    rdf.set_ontology_value(onto, mark, "first")
    rdf.set_ontology_value(onto, mark, "second")
    assert rdf.ontology_value(onto, mark) == "second"
    assert list(rdf.rdflib_graph(onto).objects(rdflib.URIRef("urn:test"), CORE.ontologyVersion)) == [rdflib.Literal("second", datatype=rdflib.XSD.string)]


def test_what_the_object_model_answers(world, robot):
    load_core(world)
    assert rdf.is_annotation_property(world[CORE_IRI + "simulatorSensorType"])
    assert not rdf.is_annotation_property(world[CORE_IRI + "hasLink"])
    (bot,) = [i for i in robot.individuals() if world[CORE_IRI + "Robot"] in i.is_a]
    assert rdf.class_iris(bot) == [CORE_IRI + "Robot"]
