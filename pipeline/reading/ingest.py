"""Safe URDF ingestion: size limit, hardened XML, structural checks, then yourdfpy.

Every refusal is a URDFError naming the problem and, where there is one, the element.
Nothing is ever fetched: no DTD, entity or external reference survives the first pass,
and meshes are never loaded.
"""
from __future__ import annotations

import hashlib
import io
import math
import os
import re
import unicodedata
import xml.etree.ElementTree as ET
from collections import Counter
from dataclasses import dataclass
from xml.parsers import expat

import defusedxml.ElementTree as DET
import yourdfpy
from defusedxml.common import DTDForbidden, EntitiesForbidden, ExternalReferenceForbidden

from urdfkb.pipeline.reading import evidence
from urdfkb.pipeline.errors import URDFError
from urdfkb.pipeline.reading.tree import JOINT_TYPES, Edge, KinematicTree, Origin, check_tree
from urdfkb.settings import MAX_BYTES, MAX_LINKS, MAX_XML_ATTRIBUTES, MAX_XML_DEPTH, MAX_XML_ELEMENTS


@dataclass(frozen=True)
class _Spec:
    """What urdfdom requires of one element's attributes."""

    required: tuple[str, ...] = ()
    any_of: tuple[str, ...] = ()
    numbers: tuple[str, ...] = ()
    vectors: tuple[str, ...] = ()


_JOINT_PARTS = {
    "origin": _Spec(vectors=("xyz", "rpy")),
    "axis": _Spec(vectors=("xyz",)),
    "limit": _Spec(required=("effort", "velocity"), numbers=("lower", "upper", "effort", "velocity")),
    "dynamics": _Spec(any_of=("damping", "friction"), numbers=("damping", "friction")),
    "safety_controller": _Spec(
        required=("k_velocity",), numbers=("soft_lower_limit", "soft_upper_limit", "k_position", "k_velocity")
    ),
    "calibration": _Spec(numbers=("rising", "falling", "reference_position")),
    "mimic": _Spec(required=("joint",), numbers=("multiplier", "offset")),
}
_LIMITED_TYPES = ("revolute", "prismatic")
_YOURDFPY_TAGS = ("link", "joint", "material")
_SHAPES = {
    "box": _Spec(required=("size",), vectors=("size",)),
    "cylinder": _Spec(required=("radius", "length"), numbers=("radius", "length")),
    "sphere": _Spec(required=("radius",), numbers=("radius",)),
    "mesh": _Spec(required=("filename",), vectors=("scale",)),
}


def load_urdf(source: str | os.PathLike | bytes, *, max_bytes: int = MAX_BYTES,
              max_links: int = MAX_LINKS) -> KinematicTree:
    """Read a URDF (bytes = the document, str/PathLike = a file path) into its kinematic tree.

    Raises URDFError for oversize, hostile, malformed or structurally invalid input, and for
    more than `max_links` links or joints (checked before any per-element work). The tree's
    `source_sha256` is the SHA-256 of the document's bytes as read.
    """
    data = _read(source, max_bytes)
    robot = _parse_hardened(data)
    _check_counts(robot, max_links)
    _validate(robot)
    _drop_invalid_geometry(robot)
    return _tree_from(_parse_with_yourdfpy(robot), robot, hashlib.sha256(data).hexdigest())


# -- 1. size and counts ----------------------------------------------------------------


def _read(source: str | os.PathLike | bytes, max_bytes: int) -> bytes:
    if isinstance(source, (bytes, bytearray)):
        _check_size(len(source), max_bytes, "document")
        return bytes(source)
    path = os.fspath(source)
    try:
        _check_size(os.stat(path).st_size, max_bytes, path)
        with open(path, "rb") as handle:
            data = handle.read(max_bytes + 1)
    except OSError as err:
        hint = " (looks like XML text: pass it as bytes)" if str(path).lstrip().startswith("<") else ""
        raise URDFError(f"cannot read URDF file: {err.strerror}{hint}", str(path)[:200]) from err
    _check_size(len(data), max_bytes, path)
    return data


def _check_size(size: int, max_bytes: int, where: str) -> None:
    if size > max_bytes:
        raise URDFError(f"URDF too large: over the {max_bytes}-byte limit ({size} bytes or more)", where)


def _check_counts(robot: ET.Element, max_links: int) -> None:
    for tag in ("link", "joint"):
        count = sum(1 for child in robot if child.tag == tag)
        if count > max_links:
            raise URDFError(f"too many {tag}s: {count}, over the limit of {max_links}", "robot")


# -- 2. hardened XML ----------------------------------------------------------------------


class _CountingBuilder(ET.TreeBuilder):
    """Builds the element tree and refuses, as the parser reaches them, more elements or attributes than
    MAX_XML_ELEMENTS / MAX_XML_ATTRIBUTES: a hostile document is refused before its tree fills memory."""

    elements = attributes = 0

    def start(self, tag, attrs):
        self.elements += 1
        self.attributes += len(attrs)
        if self.elements > MAX_XML_ELEMENTS:
            raise URDFError(f"more than {MAX_XML_ELEMENTS:,} XML elements (no real URDF has as many)", f"<{tag}>")
        if self.attributes > MAX_XML_ATTRIBUTES:
            raise URDFError(f"more than {MAX_XML_ATTRIBUTES:,} XML attributes (no real URDF has as many)", f"<{tag}>")
        return super().start(tag, attrs)


def _parse_hardened(data: bytes) -> ET.Element:
    parser = DET.DefusedXMLParser(target=_CountingBuilder(), forbid_dtd=True, forbid_entities=True,
                                  forbid_external=True)
    try:
        parser.feed(data)
        root = parser.close()
    except DTDForbidden as err:
        raise _dtd_refusal(data, err) from None
    except ET.ParseError as err:
        line, column = err.position
        raise URDFError(f"not XML: {expat.ErrorString(err.code)}", f"line {line}, column {column + 1}") from None
    _check_depth(root)
    return root


def _check_depth(root: ET.Element) -> None:
    """Refuse deep nesting, which recursive serialisers and lxml (limit 256) cannot handle."""
    level, depth = [root], 1
    while level:
        if depth > MAX_XML_DEPTH:
            raise URDFError(f"elements nested deeper than {MAX_XML_DEPTH} levels", f"<{level[0].tag}>")
        level = [child for element in level for child in element]
        depth += 1


def _dtd_refusal(data: bytes, dtd: DTDForbidden) -> URDFError:
    """Name what the DTD carries; the second look still forbids entities and external references."""
    try:
        DET.fromstring(data, forbid_dtd=False, forbid_entities=True, forbid_external=True)
    except EntitiesForbidden as err:
        if err.sysid or err.pubid:
            return URDFError(
                f"external entity '{err.name}' referring to '{err.sysid or err.pubid}' refused; nothing was fetched",
                "DOCTYPE",
            )
        return URDFError(
            f"entity declaration '{err.name}' refused: entity expansion (e.g. billion laughs) is never performed",
            "DOCTYPE",
        )
    except (ExternalReferenceForbidden, ET.ParseError):
        pass  # nothing more specific to say than the DTD itself
    external = f" referring to '{dtd.sysid}'" if dtd.sysid else ""
    return URDFError(f"document type declaration (DTD){external} refused: a URDF needs none", "DOCTYPE")


# -- 3. structure ------------------------------------------------------------------------


def _validate(robot: ET.Element) -> None:
    if robot.tag != "robot":
        raise URDFError(f"root element is <{robot.tag}>, not <robot>", f"<{robot.tag}>")
    _require_name(robot, "robot")
    _check_version(robot)
    links = [_require_name(link, f"link #{i}") for i, link in enumerate(robot.findall("link"), 1)]
    joints = [_check_joint(joint, i) for i, joint in enumerate(robot.findall("joint"), 1)]
    _check_materials(robot.findall("material"))
    check_tree(links, joints)


def _require_name(element: ET.Element, where: str) -> str:
    """The element's name; URDFError if it has none, or one holding a Unicode format character (category
    Cf: a bidi override such as U+202E, which makes a name display as another, or a zero-width one)."""
    name = element.get("name")
    if not name:
        raise URDFError(f"<{element.tag}> has no name", where)
    if (bad := format_character(name)) is not None:
        raise URDFError(f"<{element.tag}> name {name!r} holds the format character U+{ord(bad):04X} "
                        "(bidi and zero-width characters are refused in names)", where)
    return name


def format_character(text: str) -> str | None:
    """The first Unicode format character (category Cf: bidi controls, zero-width ones) in `text`, if any."""
    return next((c for c in text if unicodedata.category(c) == "Cf"), None)


def _check_version(robot: ET.Element) -> None:
    """urdfdom accepts a missing version or exactly 'major.minor' equal to 1.0."""
    version = robot.get("version")
    if version is None:
        return
    match = re.fullmatch(r"(\d+)\.(\d+)", version.strip())
    if not match:
        raise URDFError(f"malformed version '{version}': expected 'major.minor'", "robot")
    if (int(match[1]), int(match[2])) != (1, 0):
        raise URDFError(f"unsupported URDF version '{version}': only 1.0 is supported", "robot")


def _check_joint(joint: ET.Element, index: int) -> tuple[str, str, str]:
    """Check one <joint>; return (name, parent, child)."""
    name = _require_name(joint, f"joint #{index}")
    where = f"joint '{name}'"
    kind = joint.get("type")
    if kind is None:
        raise URDFError("joint has no type", where)
    if kind not in JOINT_TYPES:
        raise URDFError(f"unknown joint type '{kind}' (expected one of {', '.join(JOINT_TYPES)})", where)
    if kind in _LIMITED_TYPES and joint.find("limit") is None:
        raise URDFError(f"{kind} joint has no <limit>", where)
    for tag, spec in _JOINT_PARTS.items():
        part = joint.find(tag)
        if part is not None:
            _check_attributes(part, spec, where)
    return name, _joint_link(joint, "parent", where), _joint_link(joint, "child", where)


def _joint_link(joint: ET.Element, role: str, where: str) -> str:
    element = joint.find(role)
    link = element.get("link") if element is not None else None
    if not link:
        raise URDFError(f'joint has no <{role} link="..."/>', where)
    return link


def _check_attributes(element: ET.Element, spec: _Spec, where: str) -> None:
    """Raise URDFError unless `element` meets `spec`."""
    if problem := _attribute_problem(element, spec):
        raise URDFError(f"<{element.tag}> {problem}", where)


def _attribute_problem(element: ET.Element, spec: _Spec) -> str | None:
    """What is wrong with `element`'s attributes under `spec`, or None."""
    get = element.get
    missing = [a for a in spec.required if get(a) is None]
    if missing:
        return f"lacks required attribute '{missing[0]}'"
    if spec.any_of and all(get(a) is None for a in spec.any_of):
        return f"needs one of {' or '.join(spec.any_of)}"
    for attr, count in [(a, 1) for a in spec.numbers] + [(a, 3) for a in spec.vectors]:
        if (value := get(attr)) is not None and not _numbers(value, count):
            return f"attribute {attr}='{get(attr)}' is not {'a number' if count == 1 else '3 numbers'}"
    return None


def _numbers(text: str, count: int) -> bool:
    parts = text.split()
    try:
        return len(parts) == count and all(math.isfinite(float(p)) for p in parts)
    except ValueError:
        return False


def _check_materials(materials: list[ET.Element]) -> None:
    names = [_require_name(m, f"material #{i}") for i, m in enumerate(materials, 1)]
    duplicate = next((n for n, c in Counter(names).items() if c > 1), None)
    if duplicate is not None:
        raise URDFError(f"duplicate global material '{duplicate}'", f"material '{duplicate}'")


def _drop_invalid_geometry(robot: ET.Element) -> None:
    """Remove visuals and collisions urdfdom would drop (invalid geometry or origin), as it does."""
    for link in robot.findall("link"):
        for part in link.findall("visual") + link.findall("collision"):
            if not _valid_geometry(part):
                link.remove(part)


def _valid_geometry(part: ET.Element) -> bool:
    origin = part.find("origin")
    if origin is not None and _attribute_problem(origin, _JOINT_PARTS["origin"]):
        return False
    geometry = part.find("geometry")
    shape = geometry[0] if geometry is not None and len(geometry) else None
    return shape is not None and shape.tag in _SHAPES and not _attribute_problem(shape, _SHAPES[shape.tag])


# -- 4. yourdfpy --------------------------------------------------------------------------


def _parse_with_yourdfpy(robot: ET.Element) -> yourdfpy.URDF:
    """Hand yourdfpy the validated tree re-serialised: no DTD, entities or comments, and only
    the elements it reads (links, joints, materials), not Gazebo or transmission blocks."""
    kept = ET.Element("robot", robot.attrib)
    kept.extend(child for child in robot if child.tag in _YOURDFPY_TAGS)
    sanitised = io.BytesIO(ET.tostring(kept, encoding="utf-8"))
    try:
        return yourdfpy.URDF.load(
            sanitised, load_meshes=False, build_scene_graph=False, build_collision_scene_graph=False
        )
    except Exception as err:  # a third-party parser: whatever it raises is a refusal
        raise URDFError(f"yourdfpy could not read the document: {type(err).__name__}: {err}", "robot") from err


def _tree_from(model: yourdfpy.URDF, robot: ET.Element, sha256: str) -> KinematicTree:
    """Names, types and links from yourdfpy; origins, motion facts and per-link evidence from the validated document."""
    written = {joint.get("name"): joint for joint in robot.findall("joint")}
    links = tuple(link.name for link in model.robot.links)
    validated_links = tuple(link.get("name") for link in robot.findall("link"))
    if links != validated_links or [j.name for j in model.robot.joints] != list(written):
        raise URDFError("yourdfpy read other links or joints than were validated", "robot")
    actuated, commanded = _transmitted_joints(robot), _commanded_joints(robot)
    edges = tuple(_edge(j, written[j.name], j.name in actuated, j.name in commanded) for j in model.robot.joints)
    return KinematicTree(model.robot.name, links, edges, evidence.extract(robot, links), sha256)


def _edge(joint: yourdfpy.Joint, element: ET.Element, actuated: bool, commanded: bool) -> Edge:
    axis, limit, mimic = (element.find(tag) for tag in ("axis", "limit", "mimic"))
    lower, upper = (None, None) if limit is None else (limit.get("lower"), limit.get("upper"))
    lower_upper = (float(lower), float(upper)) if lower is not None and upper is not None else None
    return Edge(
        joint.name, joint.type, joint.parent, joint.child, _origin(element.find("origin")),
        axis=_vector(axis.get("xyz")) if axis is not None and axis.get("xyz") is not None else (1.0, 0.0, 0.0),
        limits=lower_upper,
        mimic=mimic.get("joint") if mimic is not None else None,
        mimic_multiplier=float(mimic.get("multiplier", "1")) if mimic is not None else 1.0,
        actuated=actuated,
        commanded=commanded,
        velocity=_number(limit, "velocity"),
        effort=_number(limit, "effort"),
        mimic_offset=float(mimic.get("offset", "0")) if mimic is not None else 0.0,
    )


def _number(element: ET.Element | None, attribute: str) -> float | None:
    value = element.get(attribute) if element is not None else None
    return float(value) if value is not None else None


def _transmitted_joints(robot: ET.Element) -> set[str]:
    """Joints a <transmission> drives: its <joint name=...> (ROS) or <gap_joint name=...> (PR2-era gripper)."""
    return {
        name
        for transmission in robot.iter("transmission")
        for element in transmission.iter()
        if element.tag in ("joint", "gap_joint") and (name := element.get("name"))
    }


def _commanded_joints(robot: ET.Element) -> set[str]:
    """Joints a <ros2_control> block commands: its <joint name=...> with a <command_interface>."""
    return {name for block in robot.iter("ros2_control") for joint in block.iter("joint")
            if (name := joint.get("name")) and joint.find("command_interface") is not None}


def _origin(element: ET.Element | None) -> Origin:
    """As written: yourdfpy keeps only a 4x4 matrix, and decomposing it would rewrite rpy."""
    if element is None:
        return Origin((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    return Origin(_vector(element.get("xyz")), _vector(element.get("rpy")))


def _vector(text: str | None) -> tuple[float, float, float]:
    x, y, z = map(float, text.split()) if text is not None else (0.0, 0.0, 0.0)
    return (x, y, z)
