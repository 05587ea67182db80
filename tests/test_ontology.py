"""The core ontology honours the vocabulary contract, is consistent, and loads offline and idempotently."""
import re

import owlready2
import pytest
import rdflib
from rdflib.namespace import OWL, RDF, RDFS

from urdfkb.pipeline.errors import OntologyError
from urdfkb.pipeline.knowledge import ontology, rdf
from urdfkb.pipeline.knowledge.namespaces import CORE_IRI
from urdfkb.pipeline.knowledge.ontology import Vocabulary, core_path, load_core, shapes_path, vocabulary

CORE = rdflib.Namespace(CORE_IRI)
SOSA = rdflib.Namespace("http://www.w3.org/ns/sosa/")
KIND_TYPES = {"class": OWL.Class, "subclasses": OWL.Class, "object propert": OWL.ObjectProperty,
              "data propert": OWL.DatatypeProperty}


@pytest.fixture(scope="module")
def core_graph():
    return rdflib.Graph().parse(core_path(), format="xml")


@pytest.fixture(scope="module")
def spec_text(shared):
    return (shared / "spec" / "ontology.md").read_text(encoding="utf-8")


def spec_tree(text):
    """[(name, parents)] from the spec's taxonomy block, in its order."""
    block = text.split("## Required taxonomy", 1)[1].split("```")[1]
    stack: list[str] = []
    out: list[tuple[str, list[str]]] = []
    for line in block.strip("\n").splitlines():
        depth = (len(line) - len(line.lstrip())) // 2
        name = line.split()[0]
        stack[depth:] = [name]
        parents = [stack[depth - 1]] if depth else []
        parents += re.findall(r"also under (\w+)", line)
        out.append((name, parents))
    return out


def spec_table_names(text):
    """{local name: kind prefix} from the spec's tables (header and rule rows have no kind)."""
    names = {}
    for row in re.findall(r"^\|(.+)\|$", text, re.M):
        cells = [c.strip() for c in row.split("|")]
        kind = next((k for k in KIND_TYPES if len(cells) > 1 and cells[1].startswith(k)), None)
        names.update({name: kind for name in re.findall(r"`(\w+)`", cells[0]) if kind})
    return names


def test_every_spec_name_exists_with_kind_label_and_comment(core_graph, spec_text):
    names = spec_table_names(spec_text) | {n: "class" for n, _ in spec_tree(spec_text)}
    assert {"Robot", "hasComponent", "confidence", "FixedJoint", "MicrophoneArray"} <= names.keys()
    for name, kind in names.items():
        node = CORE[name]
        assert (node, RDF.type, KIND_TYPES[kind]) in core_graph, name
        assert core_graph.value(node, RDFS.label), name
        assert core_graph.value(node, RDFS.comment), name


def test_taxonomy_matches_spec_tree_and_order(spec_text):
    tax = vocabulary()
    tree = spec_tree(spec_text)
    assert {"Component", "Sensor", "EndEffector", "BodyPart", "Subpart"} <= {name for name, _ in tree}
    for name, parents in tree:
        assert set(tax.parents(name)) == set(parents), name
    for name, _ in tree:
        expected = tuple(n for n, ps in tree if name in ps)
        assert tax.subclasses(name) == expected, name


def test_multi_parent_arrays():
    tax = vocabulary()
    assert set(tax.parents("MicrophoneArray")) == {"SensorArray", "AudioSensor"}
    assert set(tax.parents("TactileArray")) == {"SensorArray", "ContactSensor"}
    assert tax.subclasses("SensorArray") == ("MicrophoneArray", "TactileArray")
    assert tax.subclasses("AudioSensor") == ("Microphone", "MicrophoneArray")
    assert tax.subclasses("ContactSensor") == ("Bumper", "TactileSensor", "Button", "TactileArray")
    assert tax.is_a("MicrophoneArray", "AudioSensor") and tax.is_a("TactileArray", "ContactSensor")
    assert set(tax.ancestors("TactileArray")) == {"SensorArray", "ContactSensor", "Sensor", "Component"}


def test_taxonomy_queries():
    tax = vocabulary()
    assert tax is vocabulary()
    assert tax.subclasses("Component") == ("Sensor", "EndEffector", "BodyPart")
    assert tax.ancestors("StereoCamera") == ("Camera", "VisionSensor", "Sensor", "Component")
    assert tax.is_a("Camera", "Camera") and tax.is_a("RgbFrame", "Subpart") and not tax.is_a("Camera", "Subpart")
    assert tax.is_leaf("RgbFrame") and not tax.is_leaf("OpticalFrame")
    assert tax.parents("Sensor") == ("Component",)  # sosa:Sensor is alignment, not taxonomy
    assert tax.subclasses("Joint") == ("FixedJoint", "RevoluteJoint", "ContinuousJoint", "PrismaticJoint",
                                       "FloatingJoint", "PlanarJoint")
    assert tax.label("RGBDCamera") == "RGB-D camera"
    assert "colour camera" in tax.comment("RgbFrame")
    assert tax.answer("RgbFrame") == "color image" and tax.answer("Camera") == tax.label("Camera")  # altLabel, else label
    assert "Camera" in tax and "Platform" not in tax and "Nope" not in tax
    with pytest.raises(OntologyError, match="Nope"):
        tax.subclasses("Nope")


def test_definitions_are_short_distinct_and_generic():
    tax = vocabulary()
    brands = re.compile(r"kinect|realsense|velodyne|hokuyo|xtion|sick|ouster|robotiq|pr2|nao|pepper|baxter|"
                        r"panda|franka|tiago|turtlebot|husky|sawyer|kinova|jaco|hsr", re.I)
    for root in ("Component", "Subpart"):
        names = [root, *tax.subclasses_below(root)]
        for name in names:
            comment = tax.comment(name)
            assert len(comment.split()) <= 23, name
            assert not brands.search(comment), name
            siblings = tax.subclasses(name)
            assert len({tax.comment(s) for s in siblings}) == len(siblings), name


def test_axioms(core_graph):
    g = core_graph
    assert (CORE.Robot, RDFS.subClassOf, SOSA.Platform) in g
    assert (CORE.Sensor, RDFS.subClassOf, SOSA.Sensor) in g
    for cls in (SOSA.Platform, SOSA.Sensor):
        assert (cls, RDF.type, OWL.Class) in g and g.value(cls, RDFS.label)
    for prop in (CORE.urdfName, CORE.isMountedOn, CORE.confidence, CORE.hasParentLink, CORE.hasChildLink):
        assert (prop, RDF.type, OWL.FunctionalProperty) in g, prop
    assert (CORE.confidence, RDFS.range, rdflib.namespace.XSD.decimal) in g
    assert (CORE.hasLink, RDFS.range, CORE.Link) in g
    assert not list(g.triples((None, OWL.imports, None)))
    onto = rdflib.URIRef(CORE_IRI[:-1])
    assert (onto, RDF.type, OWL.Ontology) in g and g.value(onto, OWL.versionInfo)
    for name in ("abstractionModel", "votingMode", "votesPerQuestion", "generatedAt", "urdfSha256",
                 "ontologyVersion", "provenanceNote"):
        assert (CORE[name], RDF.type, OWL.AnnotationProperty) in g, name


@pytest.mark.reasoner
def test_core_is_consistent_and_every_class_satisfiable():
    world = owlready2.World()
    load_core(world)
    owlready2.sync_reasoner(world, infer_property_values=False, debug=0)
    assert list(world.inconsistent_classes()) == []


@pytest.mark.reasoner
def test_disjointness_is_enforced():
    world = owlready2.World()
    core = load_core(world)
    onto = world.get_ontology("http://example.org/clash#")
    with onto:
        thing = core.Lidar("both")
        thing.is_a.append(core.Gripper)
    with pytest.raises(owlready2.OwlReadyInconsistentOntologyError):
        owlready2.sync_reasoner(world, infer_property_values=False, debug=0)


def test_load_core_is_idempotent_and_persists(tmp_path):
    path = str(tmp_path / "store.sqlite3")
    world = owlready2.World(filename=path)
    onto = load_core(world)
    size = len(world.graph)
    assert load_core(world) is onto and len(world.graph) == size
    assert world[CORE_IRI + "StereoCamera"] is not None
    world.save()
    world.close()
    world = owlready2.World(filename=path)
    load_core(world)
    assert len(world.graph) == size and world[CORE_IRI + "RgbFrame"] is not None
    world.close()


def test_load_core_replaces_an_older_core(tmp_path):
    world = owlready2.World()
    onto = load_core(world)
    rdf.set_ontology_value(onto, ontology._LOADED_MARK, "stale")
    size = len(world.graph)
    load_core(world)
    assert rdf.ontology_value(onto, ontology._LOADED_MARK) == vocabulary().version and len(world.graph) == size


def test_core_version_is_a_short_digest():
    assert re.fullmatch(r"[0-9a-f]{16}", vocabulary().version)


def test_taxonomy_is_built_from_the_file(tmp_path):
    text = core_path().read_text(encoding="utf-8").replace(
        "Single microphone capturing sound", "A lone microphone")
    copy = tmp_path / "core.owl"
    copy.write_text(text, encoding="utf-8")
    assert Vocabulary(copy, shapes_path()).comment("Microphone").startswith("A lone microphone")


def test_options_are_offered_by_their_rank_then_in_the_files_order():
    """core:optionRank orders the body question's options (limbs before the base, as measured best); classes
    without a rank follow in the file's order."""
    tax = vocabulary()
    assert tax.offered(tax.body_classes) == ("Arm", "Leg", "Head", "Torso", "Wheel", "MobileBase")
    assert set(tax.offered(tax.body_classes)) == set(tax.body_classes)
    assert tax.offered(["Camera", "Arm", "Sensor"]) == ("Arm", "Sensor", "Camera")
