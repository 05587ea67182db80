"""The parts of data/*.yaml: read, checked, and instantiated under a name (as a macro's name or prefix).

A part file holds:
  product, maker, source {repo, file, commit, licence, expansion}
  name: the name/prefix the macro takes by default ("" where it takes a prefix); every `{n}` in the
        part's link and joint names is replaced by it
  pair: [left name, right name] where the macro takes a name (mounted twice on the pair host), or absent
  place: tool (bolted at a tool flange: grippers, hands, force-torque sensors) | sensor (anywhere)
  root: the part's first link, fixed to the host's mount link
  links: {link: {box: [x, y, z] | cylinder: [r, l] | sphere: r, mass: kg}} for links with a body
  joints: [{child, parent, type (fixed), name ({child}_joint), xyz, rpy, axis, limit: [lo, hi], mimic: [joint, k]}]
  gazebo: [{reference (a link, or absent: a model plugin), sensors: [{type, name}],
            plugin: {name, filename, tags: {tag: value}}}]
  truth: [{id, kind, classes, leaves, roots, subparts}]: roots may name "{mount}", the host link
  ignore_joints: movable joints of the part that no body part or end-effector owns
"""
from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

DATA = Path(__file__).with_name("data")
PLACES = ("tool", "sensor")
KINDS = ("sensor", "end_effector")
MOVING = ("revolute", "continuous", "prismatic")


class PartError(ValueError):
    """A part file that is not a valid part, naming the file and the problem."""


@dataclass(frozen=True)
class Part:
    key: str                    # the file stem
    product: str
    maker: str
    source: dict[str, str]
    name: str
    pair: tuple[str, str] | None
    place: str
    root: str
    links: dict[str, dict]
    joints: tuple[dict, ...]
    gazebo: tuple[dict, ...]
    truth: tuple[dict, ...]
    ignore_joints: tuple[str, ...] = ()

    def instance(self, name: str | None = None, mount: str = "{mount}") -> "Instance":
        """The part's links, joints, simulator blocks and truth under `name` (default: the macro's own),
        its truth roots naming `mount` where the part file says {mount}."""
        n = self.name if name is None else name

        def sub(text: str) -> str:
            return text.replace("{n}", n)
        joints = tuple({**j, "child": sub(j["child"]), "parent": sub(j["parent"]),
                        "name": sub(j.get("name", j["child"] + "_joint")),
                        **({"mimic": [sub(j["mimic"][0]), *j["mimic"][1:]]} if "mimic" in j else {})}
                       for j in self.joints)
        links = {sub(k): v for k, v in self.links.items()}
        names = [sub(self.root), *(j["child"] for j in joints)]
        gazebo = tuple(_substituted(g, sub) for g in self.gazebo)
        truth = tuple({**c, "id": sub(c["id"]), "leaves": [sub(x) for x in c["leaves"]],
                       "roots": [mount if r == "{mount}" else sub(r) for r in c["roots"]],
                       **({"subparts": {sub(k): v for k, v in c["subparts"].items()}} if c.get("subparts") else {})}
                      for c in self.truth)
        return Instance(self, n, sub(self.root), names, links, joints, gazebo, truth,
                        tuple(sub(j) for j in self.ignore_joints))


def _substituted(value: Any, sub) -> Any:
    if isinstance(value, str):
        return sub(value)
    if isinstance(value, dict):
        return {k: _substituted(v, sub) for k, v in value.items()}
    if isinstance(value, list):
        return [_substituted(v, sub) for v in value]
    return value


@dataclass(frozen=True)
class Instance:
    """One part under one name: what a host writes into its URDF and truth."""

    part: Part
    name: str
    root: str
    link_names: list[str]
    links: dict[str, dict]
    joints: tuple[dict, ...]
    gazebo: tuple[dict, ...]
    truth: tuple[dict, ...]
    ignore_joints: tuple[str, ...]

    def leaves(self) -> list[str]:
        parents = {j["parent"] for j in self.joints}
        return [x for x in self.link_names if x not in parents]


def load(path: Path) -> Part:
    """One part file, checked: PartError naming the file and what is wrong."""
    try:
        d = yaml.safe_load(path.read_text())
        pair = tuple(d["pair"]) if d.get("pair") else None
        part = Part(path.stem, d["product"], d["maker"], dict(d["source"]), str(d.get("name", "")),
                    pair, d["place"], d["root"], dict(d.get("links") or {}), tuple(d["joints"]),
                    tuple(d.get("gazebo") or ()), tuple(d["truth"]), tuple(d.get("ignore_joints") or ()))
    except (KeyError, TypeError, yaml.YAMLError) as e:
        raise PartError(f"{path.name}: not a part description ({type(e).__name__}: {e})") from None
    problems = check(part)
    if problems:
        raise PartError(f"{path.name}: " + "; ".join(problems))
    return part


def check(part: Part) -> list[str]:
    """What is wrong with a part (empty: nothing): its source, its tree, and its truth against its leaves."""
    problems = [f"source lacks {k}" for k in ("repo", "file", "commit", "licence") if not part.source.get(k)]
    if part.place not in PLACES:
        problems.append(f"place {part.place!r} is not one of {PLACES}")
    if part.pair and (len(part.pair) != 2 or len(set(part.pair)) != 2):
        problems.append("pair needs two different names")
    inst = part.instance()
    names = inst.link_names
    if len(set(names)) != len(names):
        problems.append("a link is the child of two joints")
    known = set(names)
    for j in inst.joints:
        if j["parent"] not in known:
            problems.append(f"joint {j['name']}: parent {j['parent']} is no link of the part")
        if j.get("type", "fixed") in ("revolute", "prismatic") and "limit" not in j:
            problems.append(f"joint {j['name']}: {j['type']} without limits")
    for link in inst.links:
        if link not in known:
            problems.append(f"links: {link} is in no joint")
    leaves = set(inst.leaves())
    owned: list[str] = [x for c in inst.truth for x in c["leaves"]]
    for c in inst.truth:
        if c.get("kind") not in KINDS or not c.get("classes") or not c.get("roots"):
            problems.append(f"truth {c.get('id')}: needs a kind of {KINDS}, classes and roots")
        if not set(c["leaves"]) <= leaves:
            problems.append(f"truth {c['id']}: not leaves of the part: {sorted(set(c['leaves']) - leaves)}")
        if not set(c.get("subparts") or {}) <= set(c["leaves"]):
            problems.append(f"truth {c['id']}: subparts not among its leaves")
    if len(set(owned)) != len(owned):
        problems.append("a leaf is in two truth components")
    if set(owned) != leaves:
        problems.append(f"leaves in no truth component: {sorted(leaves - set(owned))}")
    return problems


def load_all(folder: Path = DATA) -> list[Part]:
    """Every part of `folder`, by file name."""
    return [load(p) for p in sorted(folder.glob("*.yaml"))]


# ---- URDF elements ---------------------------------------------------------------------------

def _vec(v) -> str:
    return " ".join(f"{float(x):.6g}" for x in v)


def link_element(name: str, body: dict | None = None) -> ET.Element:
    """A <link> with a visual of the body's primitive shape and its mass, or a bare frame."""
    link = ET.Element("link", name=name)
    body = body or {}
    shape = None
    if "box" in body:
        shape = ET.Element("box", size=_vec(body["box"]))
    elif "cylinder" in body:
        shape = ET.Element("cylinder", radius=f"{body['cylinder'][0]:g}", length=f"{body['cylinder'][1]:g}")
    elif "sphere" in body:
        shape = ET.Element("sphere", radius=f"{body['sphere']:g}")
    if shape is not None:
        for tag in ("visual", "collision"):
            ET.SubElement(ET.SubElement(link, tag), "geometry").append(shape)
    if "mass" in body:
        inertial = ET.SubElement(link, "inertial")
        ET.SubElement(inertial, "mass", value=f"{body['mass']:g}")
        ET.SubElement(inertial, "inertia", ixx="1e-4", ixy="0", ixz="0", iyy="1e-4", iyz="0", izz="1e-4")
    return link


def joint_element(j: dict) -> ET.Element:
    kind = j.get("type", "fixed")
    joint = ET.Element("joint", name=j["name"], type=kind)
    ET.SubElement(joint, "parent", link=j["parent"])
    ET.SubElement(joint, "child", link=j["child"])
    ET.SubElement(joint, "origin", xyz=_vec(j.get("xyz", (0, 0, 0))), rpy=_vec(j.get("rpy", (0, 0, 0))))
    if kind in MOVING:
        ET.SubElement(joint, "axis", xyz=_vec(j.get("axis", (0, 0, 1))))
    if kind in ("revolute", "prismatic") or (kind == "continuous" and "limit" in j):  # files bound linkage bars so
        lo, hi = j["limit"]
        ET.SubElement(joint, "limit", lower=f"{lo:g}", upper=f"{hi:g}", effort="10", velocity="1")
    if "mimic" in j:
        target, *k = j["mimic"]
        ET.SubElement(joint, "mimic", joint=target, multiplier=f"{(k[0] if k else 1):g}", offset="0")
    return joint


def gazebo_elements(g: dict) -> ET.Element:
    """A <gazebo> block: sensors of SDF types on the reference link, a plugin naming its frames by its own tags."""
    block = ET.Element("gazebo", **({"reference": g["reference"]} if g.get("reference") else {}))
    holder = block
    for s in g.get("sensors") or ():
        holder = ET.SubElement(block, "sensor", type=s["type"], name=s["name"])
        ET.SubElement(holder, "update_rate").text = str(s.get("rate", 30))
    if plugin := g.get("plugin"):
        p = ET.SubElement(holder, "plugin", name=plugin["name"], filename=plugin["filename"])
        for tag, value in (plugin.get("tags") or {}).items():
            ET.SubElement(p, tag).text = str(value)
    return block
