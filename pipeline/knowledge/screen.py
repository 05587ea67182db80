"""Gates before population, each holding back for review what must not be written silently: a sensor the
model hardly believes in (`hold_unsure`), a tool with no body of its own (`hold_bodiless`), and a component or body
part that breaks ontologies/shapes.ttl (`screen`).

A sensor whose confidence (its class's share of the votes times its kind's, steps.assembly) is under
SENSOR_FLOOR is held with one line saying so: below that, over the truth robots and the probe robots of
other families, sensors were lamps, logos, antennas, feet and fragments of devices, not sensors. A sensor the file
declares a simulator sensor of its class on (on one of its links, a type the ontology aligns to a class it agrees
with: a camera declared on the body its optical frame hangs from) is written all the same, in the review queue: the
file states it. A tool is never held for that: tools below it were as often right as wrong.

The robot is built as population builds it, in a scratch world, and validated whole (pipeline.knowledge.shacl). Each
violation's focus node names the component or body part it belongs to (a sub-component, finger chain or
capability belongs to its component: namespaces.owner). Those are taken out of the abstraction and listed
in its `held`, with their violations, which the trace records and the review page shows. So what is written
passes the shapes as a whole: the store and the exports keep one gate (every write validated:
kb_server.store, urdfkb populate), with no exception for flagged parts. A component located on a held body
part loses that location, and a wheel of a held base hangs from the robot. A violation of no component or
body part (the robot, a link, a joint) is population's own fault: it is left to that gate, which refuses
the robot.
"""
from __future__ import annotations

from dataclasses import replace
from typing import Callable

import rdflib

from urdfkb import local_name
from urdfkb.pipeline.knowledge import rdf
from urdfkb.pipeline.abstraction.components import END_EFFECTOR, SENSOR, Abstraction, Component, Held
from urdfkb.pipeline.abstraction.frames import is_frame
from urdfkb.pipeline.knowledge.export import robot_graph
from urdfkb.pipeline.knowledge.namespaces import escape, owner
from urdfkb.pipeline.knowledge.ontology import vocabulary
from urdfkb.pipeline.knowledge.population import build_robot
from urdfkb.pipeline.knowledge.shacl import Violation, broken
from urdfkb.pipeline.reading.tree import KinematicTree

Record = Callable[[dict], None]
# confidence under which a sensor is held back for review, not written: over the 37 truth robots every sensor under it
# was wrong (14), over 44 probe robots of other families 30 of 33 (docs/pipeline.md). Pipeline code, so the result
# cache's key (cache.code_version) changes with it.
SENSOR_FLOOR = 0.2


def hold_unsure(tree: KinematicTree, abstraction: Abstraction, record: Record | None = None) -> Abstraction:
    """`abstraction` less its sensors of confidence under SENSOR_FLOOR that the file declares no simulator sensor of
    their class on (_declared), those in its `held`; `record` receives one {"key": "held", ...} record for each."""
    held = tuple(Held(c.name, c.kind, c.cls, c.links,
                      (f"SensorFloor: {c.name}: confidence {c.confidence:.2f} is under {SENSOR_FLOOR}, the least a "
                       "sensor is written with",))
                 for c in abstraction.components if unsure(tree, c))
    return _held(abstraction, held, "floor", record)


def unsure(tree: KinematicTree, component: Component) -> bool:
    """The component is a sensor hold_unsure holds: under SENSOR_FLOOR, with no declaration of its class."""
    return component.kind == SENSOR and component.confidence < SENSOR_FLOOR and not _declared(tree, component)


def _declared(tree: KinematicTree, component: Component) -> bool:
    """A simulator sensor declared on one of the component's links has a type the ontology aligns to a sensor class
    its class agrees with (Vocabulary.disagreeing rules it out of none)."""
    vocab = vocabulary()
    top = vocab.kinds[SENSOR].cls
    types = {s.sdf_type for link in component.links if link in tree.evidence for s in tree.evidence[link].sensors}
    declared = frozenset(d for d in vocab.declared_classes(types) if vocab.is_a(d, top))
    return bool(declared) and component.cls in vocab.subclasses_below(top) \
        and component.cls not in vocab.disagreeing(declared, top)


def hold_bodiless(tree: KinematicTree, abstraction: Abstraction, tool: str, record: Record | None = None) -> Abstraction:
    """`abstraction` less its end-effectors of no kind below `tool` (the model found no gripper, hand or suction
    cup) whose links are all bare frames (frames.is_frame) hung through fixed joints from the link a movable
    joint moves: nothing of a tool is drawn between the arm's last moving link and them, so they are the tool
    frames of an arm that carries none (a flange and tool0), held in `held` with one line. A tool whose frames hang
    from a drawn bracket fixed below the arm (a spindle's tip) keeps its frames."""
    held = tuple(Held(c.name, c.kind, c.cls, c.links,
                      (f"BodilessTool: {c.name}: an end-effector of no kind whose links ({', '.join(c.links)}) are bare "
                       f"frames on {c.root}, which a joint moves: an arm's tool frame, no device",))
                 for c in abstraction.components
                 if c.kind == END_EFFECTOR and c.cls == tool and _frames_on_moving_link(tree, c.links, c.root))
    return _held(abstraction, held, "bodiless", record)


def _frames_on_moving_link(tree: KinematicTree, links: tuple[str, ...], root: str) -> bool:
    """Every link is a bare frame, and `root` (their mount) is moved by a movable joint of its own."""
    edge = tree.parent_edge(root)
    return bool(links) and all(is_frame(tree, link) for link in links) and edge is not None and edge.movable


def _held(abstraction: Abstraction, held: tuple[Held, ...], why: str, record: Record | None) -> Abstraction:
    """`abstraction` with the `held` components taken out into its `held`, one record each."""
    if not held:
        return abstraction
    if record is not None:
        for h in held:
            record({"key": "held", "why": why, "name": h.name, "kind": h.kind, "class": h.cls,
                    "violations": list(h.violations)})
    names = {h.name for h in held}
    return replace(abstraction, held=abstraction.held + held,
                   components=tuple(c for c in abstraction.components if c.name not in names))


def screen(tree: KinematicTree, abstraction: Abstraction, record: Record | None = None) -> Abstraction:
    """`abstraction` less the components and body parts that break the shapes, those in its `held`; `record`
    receives one {"key": "held", ...} record for each, naming it and the shapes it broke, and population's
    {"key": "left_out", ...} record of each number it could not store."""
    world = rdf.new_world()
    try:
        found = broken(robot_graph(build_robot(world, tree, tree.robot_name or "robot", abstraction,
                                               record=record or _ignore)))
    finally:
        world.close()
    by_owner: dict[tuple[str, str], list[Violation]] = {}
    for violation in found:
        if isinstance(violation.focus, rdflib.URIRef) and (whose := owner(local_name(violation.focus))):
            by_owner.setdefault(whose, []).append(violation)
    held = [Held(c.name, c.kind, c.cls, c.links, _lines(vs)) for c in abstraction.components
            if (vs := by_owner.get(("component", escape(c.name))))]
    held += [Held(p.name, None, p.cls, p.links, _lines(vs)) for p in abstraction.body
             if (vs := by_owner.get(("body", escape(p.name))))]
    if record is not None:
        for h in held:
            record({"key": "held", "why": "shapes", "name": h.name, "kind": h.kind, "class": h.cls,
                    "shapes": sorted({line.split(":", 1)[0] for line in h.violations}), "violations": list(h.violations)})
    if not held:
        return abstraction
    parts, comps = {h.name for h in held if h.kind is None}, {h.name for h in held if h.kind is not None}
    return replace(abstraction, held=abstraction.held + tuple(held),
                   components=tuple(c if c.located_on not in parts else replace(c, located_on=None, side=None)
                                    for c in abstraction.components if c.name not in comps),
                   body=tuple(p if p.parent not in parts else replace(p, parent=None)
                              for p in abstraction.body if p.name not in parts))


def _ignore(record: dict) -> None:
    """Left-out numbers where no trace is kept: the store's build of the same robot logs them."""


def _lines(violations: list[Violation]) -> tuple[str, ...]:
    """One line each, the shape first, as shacl.violations gives them."""
    return tuple(sorted(map(str, violations)))
