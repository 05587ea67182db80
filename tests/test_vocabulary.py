"""The Vocabulary is all the code knows of the schema: what it reads from the core and the shapes,
and a sensor class added to a copy of the ontology is offered to the model and written out with no
code change."""
from __future__ import annotations

import owlready2
import pytest
import rdflib
from rdflib.namespace import RDF, RDFS

from tests.scripted_reasoner import scripted_reasoner
from urdfkb.pipeline.abstraction.abstractor import Abstractor
from urdfkb.pipeline.abstraction.components import END_EFFECTOR, SENSOR, Abstraction
from urdfkb.pipeline.errors import OntologyError
from urdfkb.pipeline.knowledge.export import robot_graph
from urdfkb.pipeline.reading.ingest import load_urdf
from urdfkb.pipeline.llm.scripted import ScriptedBackend
from urdfkb.pipeline.knowledge.namespaces import CORE_IRI
from urdfkb.pipeline.knowledge.ontology import Vocabulary, core_path, shapes_path, vocabulary
from urdfkb.pipeline.abstraction.oracle import Oracle
from urdfkb.pipeline.knowledge.population import build_robot
from urdfkb.pipeline.abstraction.prompts import NONE
from urdfkb.pipeline.knowledge.shacl import validate

CORE = rdflib.Namespace(CORE_IRI)
THERMOMETER = """  <owl:Class rdf:about="https://w3id.org/urdfkb/core#Thermometer">
    <rdfs:subClassOf rdf:resource="https://w3id.org/urdfkb/core#Sensor"/>
    <rdfs:label xml:lang="en">thermometer</rdfs:label>
    <rdfs:comment xml:lang="en">Sensor measuring temperature; one small frame named temp or thermo.</rdfs:comment>
    <skos:example>kettle_thermo_frame</skos:example>
  </owl:Class>
"""
KILN_BOT = b"""<robot name="kiln_bot">
  <link name="chassis"/><link name="boiler"/><link name="boiler_temp_frame"/><link name="roller"/>
  <joint name="chassis_to_boiler" type="fixed"><parent link="chassis"/><child link="boiler"/></joint>
  <joint name="boiler_to_temp" type="fixed"><parent link="boiler"/><child link="boiler_temp_frame"/></joint>
  <joint name="chassis_to_roller" type="continuous"><parent link="chassis"/><child link="roller"/>
    <axis xyz="0 1 0"/></joint>
</robot>"""


def copy_of_core(tmp_path, edit) -> Vocabulary:
    path = tmp_path / "core.owl"
    path.write_text(edit(core_path().read_text(encoding="utf-8")), encoding="utf-8")
    return Vocabulary(path, shapes_path())


def test_the_vocabulary_reads_the_schema_from_the_ontology_and_shapes():
    vocab = vocabulary()
    assert vocab is vocabulary()
    assert list(vocab.kinds) == [SENSOR, END_EFFECTOR]
    sensor, tool = vocab.kinds[SENSOR], vocab.kinds[END_EFFECTOR]
    assert (sensor.cls, sensor.subparts, sensor.noun) == ("Sensor", "SensorSubpart", "sensor")
    assert (tool.cls, tool.subparts, tool.noun) == ("EndEffector", "EndEffectorSubpart", "end-effector")
    assert sensor.mount_rule.startswith("the mount is") and "wrist or flange" in tool.mount_rule
    assert (vocab.component, vocab.subpart) == ("Component", "Subpart")
    assert vocab.kind_of("StereoCamera") == SENSOR and vocab.kind_of("Hand") == END_EFFECTOR
    assert vocab.kind_of("Wheel") is None and vocab.kind_of("Nope") is None
    assert vocab.required_part("StereoCamera") == "OpticalFrame" and vocab.required_part("Lidar") == "SensingElement"
    assert vocab.requiring_class("Lidar") == "RangingSensor" and vocab.required_part("VisionSensor") is None
    assert "image" in (vocab.part_question("OpticalFrame") or "") and vocab.part_question("SensingElement") is None
    assert vocab.has_numbered_units("TactileArray") and not vocab.has_numbered_units("Sonar")
    assert vocab.built_in("Accelerometer") and not vocab.built_in("Lidar") and not vocab.built_in("Sensor")
    assert vocab.miscounted(3, "Sensor") == {"TactileSensor", "Microphone", "Accelerometer", "Gyroscope"} and not vocab.miscounted(1, "Sensor")
    assert vocab.finger_chain_role("link") == {"Finger"} and vocab.finger_chain_role("tip") == {"ContactSurface"}
    assert vocab.finger_chain_role("carrier") == {"Palm"}
    assert vocab.joint_class("continuous") == "ContinuousJoint" and vocab.joint_class("planar") == "PlanarJoint"
    assert vocab.finger_chain_class("pivoting") == "PivotingFingerChain"
    with pytest.raises(OntologyError, match="spherical"):
        vocab.joint_class("spherical")
    assert vocab.branch("OpticalFrame") == {"OpticalFrame", "RgbFrame", "DepthFrame", "InfraredFrame"}
    assert (vocab.body_part, vocab.mobile_base, vocab.wheel) == ("BodyPart", "MobileBase", "Wheel")
    assert vocab.body_classes == ("MobileBase", "Wheel", "Arm", "Leg", "Head", "Torso")


def test_the_camera_rule_comes_from_the_shapes(tmp_path):
    text = shapes_path().read_text(encoding="utf-8")
    shapes = tmp_path / "shapes.ttl"
    shapes.write_text(text.replace("sh:targetClass :Camera ;", "sh:targetClass :StereoCamera ;"), encoding="utf-8")
    vocab = Vocabulary(core_path(), shapes)
    assert vocab.required_part("StereoCamera") == "OpticalFrame" and vocab.required_part("MonocularCamera") is None
    assert vocab.fingerprint != vocabulary().fingerprint and vocab.version == vocabulary().version


def test_what_a_cameras_frames_rule_out_comes_from_its_restrictions(tmp_path):
    """Vocabulary.unfit: ∀hasComponent.¬X and ∃hasComponent.(X ⊔ …) on the camera classes, read from the core."""
    vocab = vocabulary()

    def left(*frames):
        return set(vocab.subclasses_below("Camera")) - vocab.unfit(frozenset(frames), "Camera")
    assert left("RgbFrame", "DepthFrame") == {"RGBDCamera"}
    assert left("DepthFrame") == left("DepthFrame", "InfraredFrame") == {"DepthCamera"}
    assert left("RgbFrame") == {"MonocularCamera", "StereoCamera"}
    assert left("RgbFrame", "InfraredFrame") == {"MonocularCamera", "StereoCamera", "RGBDCamera"}
    needs = '<owl:someValuesFrom rdf:resource="https://w3id.org/urdfkb/core#RgbFrame"/>'
    assert needs in core_path().read_text(encoding="utf-8")
    vocab = copy_of_core(tmp_path, lambda text: text.replace(needs, needs.replace("RgbFrame", "InfraredFrame")))
    assert "RGBDCamera" in vocab.unfit(frozenset({"RgbFrame", "DepthFrame"}), "Camera")  # it now needs an IR frame


def test_where_a_component_may_sit_comes_from_its_restriction(tmp_path):
    """Vocabulary.placement: on the class or its nearest ancestor, any union, intersection or complement."""
    assert vocabulary().placement("Bumper") == "Bumper ⊑ ∀isLocatedOn.(MobileBase ⊔ Leg)"
    assert vocabulary().placement("Button") is None and vocabulary().placement("ContactSensor") is None
    bumper = '<owl:Class rdf:about="https://w3id.org/urdfkb/core#Bumper">'
    contact = '<owl:Class rdf:about="https://w3id.org/urdfkb/core#ContactSensor">'
    other = ('<owl:intersectionOf rdf:parseType="Collection"><rdf:Description rdf:about="https://w3id.org/urdfkb/core#'
             'BodyPart"/><owl:Class><owl:complementOf rdf:resource="https://w3id.org/urdfkb/core#Head"/></owl:Class>'
             '</owl:intersectionOf>')

    def restriction(text: str) -> tuple[int, int]:
        """Where the Bumper's restriction (its second rdfs:subClassOf) starts and ends."""
        start = text.index("<rdfs:subClassOf>", text.index(bumper))
        return start, text.index("</rdfs:subClassOf>", start) + len("</rdfs:subClassOf>")

    def moved(text):  # on ContactSensor instead, with another filler
        start, end = restriction(text)
        axiom = text[start:end]
        axiom = axiom[:axiom.index("<owl:unionOf")] + other + axiom[axiom.index("</owl:unionOf>") + len("</owl:unionOf>"):]
        return text[:start].replace(contact, contact + axiom) + text[end:]

    def twice(text):
        start, end = restriction(text)
        return text.replace(bumper, bumper + text[start:end])
    vocab = copy_of_core(tmp_path, moved)
    assert vocab.placement("Bumper") == vocab.placement("Button") == "ContactSensor ⊑ ∀isLocatedOn.(BodyPart ⊓ ¬Head)"
    with pytest.raises(OntologyError, match="Bumper says twice where it is located"):
        copy_of_core(tmp_path, twice)


def test_a_kind_must_say_its_branch_noun_and_mount_rule(tmp_path):
    def drop_rule(text):
        start = text.index("<core:mountRule")
        return text[:start] + text[text.index("</core:mountRule>", start) + len("</core:mountRule>"):]
    with pytest.raises(OntologyError, match="Sensor carries core:componentKind"):
        copy_of_core(tmp_path, drop_rule)


def test_the_body_classes_the_code_gives_a_role_must_be_in_the_ontology(tmp_path):
    wheel = '<owl:Class rdf:about="https://w3id.org/urdfkb/core#Wheel">\n    <rdfs:subClassOf rdf:resource="https://w3id.org/urdfkb/core#'
    with pytest.raises(OntologyError, match="no class Wheel directly below BodyPart"):
        copy_of_core(tmp_path, lambda text: text.replace(wheel + "BodyPart", wheel + "Component"))


def test_a_sensor_class_added_to_the_ontology_is_offered_and_written_out(tmp_path):
    anchor = '  <owl:Class rdf:about="https://w3id.org/urdfkb/core#SensorArray">'
    vocab = copy_of_core(tmp_path, lambda text: text.replace(anchor, THERMOMETER + anchor))
    assert vocab.subclasses("Sensor")[-2:] == ("Thermometer", "SensorArray")
    asked = []

    def model(q):
        asked.append(q)
        stage, _, subject = q.key.partition(":")
        if stage == "check":
            return "sensor"
        if stage == "identify":
            return "sensor" if subject == "boiler_temp_frame" else NONE
        if q.key == "pre:boiler_temp_frame@Sensor":
            return "thermometer"
        return q.options[0]

    tree = load_urdf(KILN_BOT)
    abstractor = Abstractor(Oracle(ScriptedBackend(model)), vocab, reasoner=scripted_reasoner)
    found = abstractor.run(tree)
    (comp,) = found.components
    assert (comp.kind, comp.cls, comp.root) == (SENSOR, "Thermometer", "boiler")
    pre = next(q for q in asked if q.key == "pre:boiler_temp_frame@Sensor")
    assert "thermometer" in pre.options
    assert ("- thermometer: Sensor measuring temperature; one small frame named temp or thermo."
            " Example: kettle_thermo_frame") in pre.system

    abstraction = Abstraction((comp,), body=tuple(found.body))
    with pytest.raises(OntologyError, match="Thermometer"):  # the packaged core does not know it
        build_robot(owlready2.World(), tree, "kiln_bot", abstraction)
    graph = robot_graph(build_robot(owlready2.World(), tree, "kiln_bot", abstraction, vocab=vocab), vocab=vocab)
    node = next(graph.subjects(RDF.type, CORE.Thermometer))
    assert (node, CORE.isMountedOn, None) in graph
    assert graph.value(CORE.Thermometer, RDFS.label) == rdflib.Literal("thermometer", lang="en")
    conforms, report = validate(graph, vocab)
    assert conforms, report


def test_an_accelerometers_and_a_gyroscopes_frames_written_as_one_device_are_an_imu():
    """core:elementCount on Accelerometer and Gyroscope: each is one sensing frame, so an inertial device written with
    two (an accelerometer's and a gyroscope's frames at one point, one device by structure) can only be an IMU."""
    tax = vocabulary()
    assert tax.miscounted(2, "InertialSensor") == {"Accelerometer", "Gyroscope"}
    assert not tax.miscounted(1, "InertialSensor")
