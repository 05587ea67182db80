"""Every IRI urdfkb names or mints, in one place (W3C vocabularies come from rdflib.namespace: PROV, SOSA, OWL...).

The core ontology is `CORE_ONTOLOGY_IRI` with its terms in `CORE`; in the knowledge base it is the named
graph `CORE_GRAPH`. Each robot is its own ontology and named graph, `robot_iri(name)`, holding the
individuals `robot`, `link_<l>`, `joint_<j>`, `comp_<c>`, `sub_<c>.<l>`, `body_<b>`, `finger_<c>.<chain>`
and `cap_<c>`, `cap_<c>.<property>` (a sensor's SSN capability and its properties; the functions below),
each name escaped: every byte outside ASCII letters, digits, '-', '_' and '~' is percent-encoded (so '.'
is free as a separator), which makes any URDF name a valid IRI and keeps distinct names distinct.
Reviewers' corrections of a robot are the graph `corrections_iri(name)`, in `REVIEW` terms. SSN's System
Capabilities (`SSN_SYSTEM`) and schema.org (`SCHEMA`, http as SSN's examples write it) are not in rdflib.
"""
from __future__ import annotations

import string

from rdflib import Namespace

from urdfkb.pipeline.errors import OntologyError

CORE_IRI = "https://w3id.org/urdfkb/core#"
CORE_ONTOLOGY_IRI = CORE_IRI[:-1]
CORE = Namespace(CORE_IRI)
CORE_GRAPH = CORE_IRI  # owlready2 keeps an ontology in the graph named by its base IRI
REVIEW = Namespace("https://w3id.org/urdfkb/review#")
SSN_SYSTEM = Namespace("http://www.w3.org/ns/ssn/systems/")
SCHEMA = Namespace("http://schema.org/")
ROBOT_BASE = "https://w3id.org/urdfkb/robot/"
ROBOT = "robot"  # the local name of every robot's core:Robot individual

_SAFE = frozenset((string.ascii_letters + string.digits + "-_~").encode())


def escape(name: str) -> str:
    """Percent-encode the UTF-8 bytes of `name` outside [A-Za-z0-9_~-]; injective."""
    return "".join(chr(b) if b in _SAFE else f"%{b:02X}" for b in name.encode("utf-8", "surrogatepass"))


def robot_iri(robot_name: str) -> str:
    """Namespace (ending in '#') of the robot's own ontology, also its named graph."""
    if not robot_name:
        raise OntologyError("robot name is empty")
    return f"{ROBOT_BASE}{escape(robot_name)}#"


def corrections_iri(robot_name: str) -> str:
    """The named graph (owlready2 ontology) holding the reviewers' corrections of robot `robot_name`."""
    return f"{ROBOT_BASE}{escape(robot_name)}/corrections#"


def link_local(link: str) -> str:
    return "link_" + escape(link)


def joint_local(joint: str) -> str:
    return "joint_" + escape(joint)


def component_local(component: str) -> str:
    return "comp_" + escape(component)


def component_iri(robot_ns: str, component: str) -> str:
    """A component's individual in the robot ontology `robot_ns` (a `robot_iri`)."""
    return robot_ns + component_local(component)


def subcomponent_local(component: str, link: str) -> str:
    return f"sub_{escape(component)}.{escape(link)}"


def body_part_local(part: str) -> str:
    return "body_" + escape(part)


def finger_chain_local(component: str, chain: str) -> str:
    return f"finger_{escape(component)}.{escape(chain)}"


def capability_local(component: str, prop: str | None = None) -> str:
    """A sensor's SSN system capability (`cap_<c>`), or one of its system properties (`cap_<c>.frequency`)."""
    return f"cap_{escape(component)}" + (f".{prop}" if prop else "")


def owner(local: str) -> tuple[str, str] | None:
    """Whose an individual is, from its local name: ("component", escaped name) for `comp_<c>` and the
    `sub_<c>.<l>`, `finger_<c>.<chain>` and `cap_<c>...` it owns, ("body", escaped name) for `body_<b>`;
    None for the robot, its links and joints."""
    prefix, _, rest = local.partition("_")
    if not rest or prefix not in _OWNED:
        return None
    return _OWNED[prefix], rest.split(".", 1)[0]


_OWNED = {"comp": "component", "sub": "component", "finger": "component", "cap": "component", "body": "body"}
