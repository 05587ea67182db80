"""SHACL before population: every component and body part is checked against ontologies/shapes.ttl before
the robot is written, and one that breaks them is held back for review, never silently written.

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
from urdfkb.pipeline.abstraction.components import Abstraction, Held
from urdfkb.pipeline.knowledge.export import robot_graph
from urdfkb.pipeline.knowledge.namespaces import escape, owner
from urdfkb.pipeline.knowledge.population import build_robot
from urdfkb.pipeline.knowledge.shacl import Violation, broken
from urdfkb.pipeline.reading.tree import KinematicTree

Record = Callable[[dict], None]


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
            record({"key": "held", "name": h.name, "kind": h.kind, "class": h.cls,
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
