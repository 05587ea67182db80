"""Populate one robot as its own OWL ontology: structure from the tree, components from an abstraction, and
what each part can do from the URDF (pipeline.abstraction.capabilities: reference frames, declared specifications, reach...).

The ontology and its individuals are named by pipeline.knowledge.namespaces (`robot_iri(name)`, `link_<l>`, `comp_<c>`...).
Every number read or computed is written only where it is storable (_Numbers): one that is not finite or has
no plain decimal form (joint limits of ±1e308 overflow a reach, an opening or a range) is left out, with a record.
"""
from __future__ import annotations

import logging
import math
from datetime import datetime, timezone
from typing import Callable

from urdfkb import __version__
from urdfkb.pipeline.abstraction import capabilities
from urdfkb.pipeline.knowledge import rdf
from urdfkb.pipeline.abstraction.components import SENSOR, SIDES, Abstraction, BodyPart, Component
from urdfkb.pipeline.errors import OntologyError
from urdfkb.pipeline.knowledge.namespaces import (CORE_IRI, ROBOT, SCHEMA, SSN_SYSTEM, body_part_local, capability_local,
                                        component_local, finger_chain_local, joint_local, link_local, robot_iri,
                                        subcomponent_local)
from urdfkb.pipeline.knowledge.ontology import Vocabulary, load_core, vocabulary
from urdfkb.pipeline.abstraction.frames import viewpoints
from urdfkb.pipeline.reading.tree import KinematicTree

log = logging.getLogger(__name__)
Record = Callable[[dict], None]
MAX_DECIMAL = 1e16    # from here Python, so owlready2, writes a float with an exponent, which xsd:decimal has not
MAX_INTEGER = 2 ** 63  # SQLite's integers are 64-bit

# Provenance keys the pipeline writes (oracle, runner) -> core annotation properties.
PROVENANCE_ALIASES = {
    "model": "abstractionModel",
    "vote": "votingMode",
    "votes": "votesPerQuestion",
    "temperature": "samplingTemperature",
    "mode": "abstractionMode",
    "llm_calls": "llmCalls",
    "prompt_tokens": "tokensEvaluated",
    "declared_constraints": "declaredSensorConstraints",
    "seconds": "wallTimeSeconds",
}


def stamp(tree: KinematicTree) -> dict[str, str]:
    """What every populated robot says of the populate that wrote it: when (UTC), with which urdfkb,
    from which URDF document (its SHA-256, where the tree was read from one)."""
    facts = {"generatedAt": datetime.now(timezone.utc).isoformat(timespec="seconds"), "softwareVersion": __version__}
    if tree.source_sha256:
        facts["urdfSha256"] = tree.source_sha256
    return facts


def build_robot(world: rdf.World, tree: KinematicTree, robot_name: str, abstraction: Abstraction | None = None,
                provenance: dict[str, str] | None = None, vocab: Vocabulary | None = None,
                record: Record | None = None) -> rdf.Ontology:
    """Write the robot as ontology `robot_iri(robot_name)` in `world`, replacing any earlier version.

    The abstraction is checked first (classes, links, confidences, names), so a bad one raises
    OntologyError with nothing written. Provenance (abstraction.provenance, then `provenance`)
    is annotated on the Robot: keys naming a core annotation property (or in PROVENANCE_ALIASES)
    as that property, others as provenanceNote "key=value"; ontologyVersion defaults to the core's
    version and generatedAt, softwareVersion and urdfSha256 to `stamp(tree)` (the runner stamps its
    abstractions, so a rebuild for a correction keeps the time of the populate).
    Classes come from `vocab` (the packaged vocabulary by default), which is loaded into `world`.
    A number left out (_Numbers) gives `record` one {"key": "left_out", ...} record (default: a logged warning).
    """
    vocab = vocab or vocabulary()
    components = abstraction.components if abstraction else ()
    body = abstraction.body if abstraction else ()
    _check_components(vocab, tree, components)
    _check_body(vocab, tree, body, components)
    notes = {"ontologyVersion": vocab.version, **stamp(tree), **(abstraction.provenance if abstraction else {}),
             **(provenance or {})}
    load_core(world, vocab)
    onto = _fresh_ontology(world, robot_iri(robot_name))
    numbers = _Numbers(world, robot_name, record or _warn)
    with onto:
        robot = _new(world, onto, "Robot", ROBOT, robot_name)
        _set(world, "urdfName", robot, tree.robot_name)
        links, joints = _add_structure(world, onto, robot, tree, vocab, numbers)
        parts = _add_body(world, onto, robot, body, links, joints)
        camera = vocab.domain("viewpointCount")
        cameras = [link for comp in components if vocab.is_a(comp.cls, camera) for link in _leaves(tree, comp)]
        for comp in components:
            individual, subs = _add_component(world, onto, robot, comp, links, joints, parts)
            _add_fingers(world, onto, individual, comp, joints)
            if comp.kind == SENSOR:
                _add_sensor_facts(world, onto, individual, subs, comp, tree, vocab, links, numbers, cameras)
            elif vocab.is_a(comp.cls, vocab.domain("maxOpeningMetres")):
                numbers.decimal(CORE_IRI + "maxOpeningMetres", individual, capabilities.opening(tree, comp.links))
        _add_body_facts(world, tree, vocab, body, components, parts, numbers)
        _annotate(world, robot, notes)
    return onto


def _check_components(vocab: Vocabulary, tree, components: tuple[Component, ...]) -> None:
    known = set(tree.links)
    names: set[str] = set()
    for comp in components:
        where = f"component {comp.name!r}"
        if comp.name in names:
            raise OntologyError(f"{where} appears twice")
        names.add(comp.name)
        kind = vocab.kinds.get(comp.kind)
        if kind is None:
            raise OntologyError(f"{where} has unknown kind {comp.kind!r}")
        _check_class(vocab, comp.cls, kind.cls, where)
        _check_confidence(comp.confidence, where)
        _check_link(comp.root, known, where)
        sub_links: set[str] = set()
        for sub in comp.subcomponents:
            _check_class(vocab, sub.cls, vocab.subpart, f"{where}, sub-link {sub.link!r}")
            _check_confidence(sub.confidence, f"{where}, sub-link {sub.link!r}")
            _check_link(sub.link, known, where)
            if sub.link in sub_links:
                raise OntologyError(f"{where} lists sub-link {sub.link!r} twice")
            sub_links.add(sub.link)
        _check_fingers(vocab, tree, comp, where)


def _check_body(vocab: Vocabulary, tree, body: tuple[BodyPart, ...], components: tuple[Component, ...]) -> None:
    known, joints = set(tree.links), {e.joint for e in tree.edges}
    names = {part.name for part in body}
    if len(names) != len(body):
        raise OntologyError("a body part name appears twice")
    for part in body:
        where = f"body part {part.name!r}"
        _check_class(vocab, part.cls, vocab.body_part, where)
        _check_confidence(part.confidence, where)
        for link in (*part.links, *([part.root] if part.root else [])):
            _check_link(link, known, where)
        _check_joints(part.joints, joints, where)
        if part.side not in (None, *SIDES):
            raise OntologyError(f"{where}: side {part.side!r} is not one of {', '.join(SIDES)}")
        if part.parent is not None and part.parent not in names:
            raise OntologyError(f"{where} is under unknown body part {part.parent!r}")
    for comp in components:
        where = f"component {comp.name!r}"
        _check_joints(comp.joints, joints, where)
        if comp.located_on is not None and comp.located_on not in names:
            raise OntologyError(f"{where} is located on unknown body part {comp.located_on!r}")
        if comp.side not in (None, *SIDES):
            raise OntologyError(f"{where}: side {comp.side!r} is not one of {', '.join(SIDES)}")


def _check_joints(names, joints: set[str], where: str) -> None:
    unknown = [j for j in names if j not in joints]
    if unknown:
        raise OntologyError(f"{where} names joint {unknown[0]!r}, which is not in the URDF")


def _check_fingers(vocab: Vocabulary, tree, comp: Component, where: str) -> None:
    names = {f.name for f in comp.fingers}
    joints = {e.joint for e in tree.edges}
    for finger in comp.fingers:
        _check_class(vocab, finger.chain_class, "FingerChain", f"{where}, finger chain {finger.name!r}")
        if finger.drive not in joints:
            raise OntologyError(f"{where}, finger chain {finger.name!r} names joint {finger.drive!r}, which is not in the URDF")
        unknown = [n for n in (*finger.opposes, *finger.moves_with, finger.mimics) if n is not None and n not in names]
        if unknown:
            raise OntologyError(f"{where}, finger chain {finger.name!r} refers to unknown chain {unknown[0]!r}")


def _check_class(vocab: Vocabulary, cls: str, root: str, where: str) -> None:
    if cls not in vocab or not vocab.is_a(cls, root):
        raise OntologyError(f"{where}: class {cls!r} is not a {root} class of the core ontology")


def _check_confidence(value: float, where: str) -> None:
    if not (isinstance(value, (int, float)) and math.isfinite(value) and 0 <= value <= 1):
        raise OntologyError(f"{where}: confidence {value!r} is not a number in [0, 1]")


def _check_link(link: str, known: set[str], where: str) -> None:
    if link not in known:
        raise OntologyError(f"{where} names link {link!r}, which is not in the URDF")


def _fresh_ontology(world: rdf.World, iri: str) -> rdf.Ontology:
    old = world.ontologies.get(iri)
    if old is not None:
        old.destroy()
    return world.get_ontology(iri)


def _new(world, onto, cls: str, local: str, label: str):
    individual = world[CORE_IRI + cls](local, namespace=onto)
    individual.label = [label]
    return individual


def _set(world, prop: str, subject, value) -> None:
    world[CORE_IRI + prop][subject].append(value)


def _add_structure(world, onto, robot, tree, vocab: Vocabulary, numbers: _Numbers) -> tuple[dict, dict]:
    links = {}
    for name in tree.links:
        link = links[name] = _new(world, onto, "Link", link_local(name), name)
        _set(world, "urdfName", link, name)
        _set(world, "hasLink", robot, link)
    joints = {}
    for edge in tree.edges:
        joint = joints[edge.joint] = _new(world, onto, vocab.joint_class(edge.joint_type), joint_local(edge.joint),
                                          edge.joint)
        _set(world, "urdfName", joint, edge.joint)
        _set(world, "hasParentLink", joint, links[edge.parent])
        _set(world, "hasChildLink", joint, links[edge.child])
        _set(world, "hasJoint", robot, joint)
        _add_joint_facts(numbers, joint, edge)
    for edge in tree.edges:
        if edge.mimic is not None and edge.mimic in joints:
            _set(world, "isMimicOf", joints[edge.joint], joints[edge.mimic])
    return links, joints


def _add_joint_facts(numbers: _Numbers, joint, edge) -> None:
    """Limits, axis and mimic coefficients: "how far can you turn your head" is one query."""
    facts = {"axisX": edge.axis[0], "axisY": edge.axis[1], "axisZ": edge.axis[2],
             "velocityLimit": edge.velocity, "effortLimit": edge.effort}
    if edge.limits is not None:
        facts |= {"lowerLimit": edge.limits[0], "upperLimit": edge.limits[1]}
    if edge.mimic is not None:
        facts |= {"mimicMultiplier": edge.mimic_multiplier, "mimicOffset": edge.mimic_offset}
    for prop, value in facts.items():
        numbers.decimal(CORE_IRI + prop, joint, value)


def _add_body(world, onto, robot, body: tuple[BodyPart, ...], links: dict, joints: dict) -> dict:
    """Body parts: `body_<b>` individuals under the robot (or their parent part), with their joints and links."""
    parts = {}
    for part in body:
        ind = parts[part.name] = _new(world, onto, part.cls, body_part_local(part.name), part.name)
        _set(world, "confidence", ind, _decimal(part.confidence))
        if part.root is not None:
            _set(world, "isMountedOn", ind, links[part.root])
        if part.side is not None:
            _set(world, "side", ind, part.side)
        for joint in part.joints:
            _set(world, "hasJoint", ind, joints[joint])
        for link in part.links:
            _set(world, "hasLink", ind, links[link])
    for part in body:
        _set(world, "hasComponent", parts[part.parent] if part.parent else robot, parts[part.name])
    return parts


def _add_component(world, onto, robot, comp: Component, links: dict, joints: dict, parts: dict):
    ind = _new(world, onto, comp.cls, component_local(comp.name), comp.name)
    _set(world, "confidence", ind, _decimal(comp.confidence))
    _set(world, "isMountedOn", ind, links[comp.root])
    _set(world, "hasComponent", robot, ind)
    for joint in comp.joints:
        _set(world, "hasJoint", ind, joints[joint])
    if comp.located_on is not None:
        _set(world, "isLocatedOn", ind, parts[comp.located_on])
    if comp.side is not None:
        _set(world, "side", ind, comp.side)
    subs = {}
    for sub in comp.subcomponents:
        part = subs[sub.link] = _new(world, onto, sub.cls, subcomponent_local(comp.name, sub.link), sub.link)
        _set(world, "hasLink", part, links[sub.link])
        _set(world, "confidence", part, _decimal(sub.confidence))
        _set(world, "hasComponent", ind, part)
    return ind, subs


# The SSN system properties of a SensorSpec (the field(s) holding its value, or its minimum and maximum; its
# UN/CEFACT unit code)
_SYSTEM_PROPERTIES = (("Frequency", "frequency", ("rate",), "HTZ"), ("MeasurementRange", "range", ("min_range", "max_range"), "MTR"),
                      ("Resolution", "resolution", ("resolution",), "MTR"))


def _leaves(tree, comp: Component) -> list[str]:
    return [link for link in comp.links if tree.is_leaf(link)] or list(comp.links)


def _add_sensor_facts(world, onto, ind, subs: dict, comp: Component, tree, vocab: Vocabulary, links: dict,
                      numbers: _Numbers, cameras: list[str]) -> None:
    """A camera's viewpoint count (frames.viewpoints over its leaf links, beside the other `cameras`' leaves, so that
    a reasoner can check its class against core:viewpointCount's restrictions) and optical frames; a sensor's reference frames and declared
    specification (capabilities): the numbers SSN names as an ssn-system:SystemCapability with its system
    properties, the others as core data, and what a ranging sensor emits where its class allows it."""
    if vocab.is_a(comp.cls, vocab.domain("viewpointCount")):
        leaves = _leaves(tree, comp)
        if (views := viewpoints(tree, leaves, cameras)) is not None:
            _set(world, "viewpointCount", ind, views)
    if vocab.is_a(comp.cls, vocab.domain("hasOpticalFrame")):
        for sub in comp.subcomponents:
            if vocab.is_a(sub.cls, vocab.range("hasOpticalFrame")):
                _set(world, "hasOpticalFrame", ind, subs[sub.link])
    spec = capabilities.sensor_spec(tree, vocab, comp)
    for link in spec.reference_frames:
        _set(world, "hasReferenceFrame", ind, links[link])
    numbers.decimal(CORE_IRI + "horizontalFieldOfViewRadians", ind, spec.fov)
    numbers.integer(CORE_IRI + "raySamples", ind, spec.samples)
    ranging = vocab.domain("rangingRadiation")
    if spec.radiation and vocab.is_a(comp.cls, ranging) and comp.cls not in vocab.emitting_otherwise(spec.radiation, ranging):
        _set(world, "rangingRadiation", ind, spec.radiation)
    if spec.image is not None:
        numbers.integer(CORE_IRI + "imageWidthPixels", ind, spec.image[0])
        numbers.integer(CORE_IRI + "imageHeightPixels", ind, spec.image[1])
    stated = [(cls, key, [getattr(spec, f) for f in names], unit) for cls, key, names, unit in _SYSTEM_PROPERTIES]
    stated = [s for s in stated if any(v is not None for v in s[2])]
    if not stated:
        return
    capability = world[SSN_SYSTEM.SystemCapability](capability_local(comp.name), namespace=onto)
    world[SSN_SYSTEM.hasSystemCapability][ind].append(capability)
    for cls, key, values, unit in stated:
        prop = world[SSN_SYSTEM[cls]](capability_local(comp.name, key), namespace=onto)
        world[SSN_SYSTEM.hasSystemProperty][capability].append(prop)
        names = ("value",) if len(values) == 1 else ("minValue", "maxValue")
        for name, value in zip(names, values):
            numbers.decimal(SCHEMA[name], prop, value)
        world[SCHEMA.unitCode][prop].append(unit)


def _add_body_facts(world, tree, vocab: Vocabulary, body: tuple[BodyPart, ...], components: tuple[Component, ...],
                    parts: dict, numbers: _Numbers) -> None:
    """An arm's degrees of freedom and reach, a head's pan and tilt ranges (pipeline.abstraction.capabilities)."""
    for part in body:
        ind = parts[part.name]
        if vocab.is_a(part.cls, vocab.domain("reachMetres")):
            _set(world, "degreesOfFreedom", ind, capabilities.degrees_of_freedom(tree, part.joints))
            tool = capabilities.tool_point(tree, vocab, part, components)
            if tool is not None:
                numbers.decimal(CORE_IRI + "reachMetres", ind, capabilities.reach(tree, part.joints[0], tool))
        elif vocab.is_a(part.cls, vocab.domain("panRangeRadians")):
            for prop, value in zip(("panRangeRadians", "tiltRangeRadians"), capabilities.head_ranges(tree, part.joints)):
                numbers.decimal(CORE_IRI + prop, ind, value)


def _add_fingers(world, onto, owner, comp: Component, joints: dict) -> None:
    """The component's finger chains as structural facts: `finger_<c>.<chain>` individuals."""
    chains = {}
    for finger in comp.fingers:
        chain = chains[finger.name] = _new(world, onto, finger.chain_class,
                                           finger_chain_local(comp.name, finger.name), finger.name)
        if finger.thumb:
            chain.is_a.append(world[CORE_IRI + "ThumbChain"])
        _set(world, "hasDriveJoint", chain, joints[finger.drive])
        _set(world, "hasFingerChain", owner, chain)
    for finger in comp.fingers:
        for prop, others in (("opposes", finger.opposes), ("movesWith", finger.moves_with),
                             ("isMimicOf", (finger.mimics,) if finger.mimics else ())):
            for other in others:
                _set(world, prop, chains[finger.name], chains[other])


def _decimal(value: float) -> float:
    """Owlready2 writes floats as xsd:decimal; 4 places keep the lexical form non-exponential below MAX_DECIMAL."""
    return round(float(value), 4)


class _Numbers:
    """Writes a robot's numbers, each only where it is storable: a decimal finite and under MAX_DECIMAL in size,
    an integer under MAX_INTEGER; `record` receives a {"key": "left_out", ...} record for any other, which is
    left out. None (nothing stated or computed) is left out without a record."""

    def __init__(self, world: rdf.World, robot: str, record: Record):
        self.world, self.robot, self.record = world, robot, record

    def decimal(self, prop: str, subject, value: float | None) -> None:
        if value is None:
            return
        if not math.isfinite(value) or abs(_decimal(value)) >= MAX_DECIMAL:
            self._leave_out(prop, subject, value, "not a finite number" if not math.isfinite(value)
                            else "no plain decimal form: 1e16 or more in size")
        else:
            self.world[prop][subject].append(_decimal(value))

    def integer(self, prop: str, subject, value: int | None) -> None:
        if value is None:
            return
        if abs(value) >= MAX_INTEGER:
            self._leave_out(prop, subject, value, "beyond a 64-bit integer")
        else:
            self.world[prop][subject].append(value)

    def _leave_out(self, prop: str, subject, value: float, why: str) -> None:
        self.record({"key": "left_out", "robot": self.robot, "subject": subject.name, "property": prop.split("#")[-1].split("/")[-1],
                     "value": f"{value:.6g}", "why": why})


def _warn(record: dict) -> None:
    log.warning("robot %s: %s of %s left out: %s (%s)", record["robot"], record["property"], record["subject"],
                record["value"], record["why"])


def _annotate(world, robot, notes: dict[str, str]) -> None:
    for key, value in notes.items():
        prop = world[CORE_IRI + PROVENANCE_ALIASES.get(key, key)]
        if rdf.is_annotation_property(prop):
            prop[robot].append(datetime.fromisoformat(value) if key == "generatedAt" else str(value))  # xsd:dateTime
        else:
            _set(world, "provenanceNote", robot, f"{key}={value}")
