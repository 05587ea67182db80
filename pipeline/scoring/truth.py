"""The ground truth of the evaluation (../shared/spec/evaluation.md): truth files, read and checked, and the folds
of robot families the benchmarks group them in.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Mapping

import yaml

from urdfkb.pipeline.abstraction.components import KINDS, SIDES
from urdfkb.pipeline.errors import UrdfkbError


@dataclass(frozen=True)
class TruthComponent:
    id: str
    kind: str
    classes: frozenset[str]
    roots: frozenset[str]
    leaves: frozenset[str]
    subparts: Mapping[str, frozenset[str]] = field(default_factory=dict, hash=False)


@dataclass(frozen=True)
class Alternative:
    """Another accepted partition: truth components ``replace`` may be read as ``with_``."""

    replace: tuple[str, ...]
    with_: tuple[TruthComponent, ...]


@dataclass(frozen=True)
class TruthBodyPart:
    """One part of the truth's ``body:`` section; ``links`` keeps file order (the first one
    identifies a part without joints)."""

    id: str
    classes: frozenset[str]
    roots: frozenset[str]
    joints: frozenset[str]
    links: tuple[str, ...] = ()
    side: str | None = None


@dataclass(frozen=True)
class TruthBody:
    ignore_joints: frozenset[str]
    parts: tuple[TruthBodyPart, ...]


@dataclass(frozen=True)
class Truth:
    robot: str
    urdf: str
    ignore: frozenset[str]
    components: tuple[TruthComponent, ...]
    alternatives: tuple[Alternative, ...] = ()
    body: TruthBody | None = None     # None: the file has no body section (body metrics undefined)

def _truth_component(d: dict) -> TruthComponent:
    if d["kind"] not in KINDS:
        raise ValueError(f"truth component {d['id']}: unknown kind {d['kind']!r}")
    leaves = frozenset(d["leaves"])
    subparts = {k: frozenset(v) for k, v in (d.get("subparts") or {}).items()}
    if not set(subparts) <= leaves:
        raise ValueError(f"truth component {d['id']}: subparts not among its leaves")
    return TruthComponent(str(d["id"]), d["kind"], frozenset(d["classes"]), frozenset(d["roots"]),
                          leaves, subparts)


def _truth_body(data: dict, path) -> TruthBody:
    ignore = frozenset(data.get("ignore_joints") or ())
    parts: list[TruthBodyPart] = []
    owner: dict[str, str] = {}  # joint → the part listing it
    for d in data.get("parts") or []:
        where = f"{path}: body part {d.get('id')!r}"
        part = TruthBodyPart(str(d["id"]), frozenset(d["classes"]), frozenset(d.get("roots") or ()),
                             frozenset(d.get("joints") or ()), tuple(d.get("links") or ()), d.get("side"))
        if not part.classes:
            raise ValueError(f"{where}: no accepted class")
        if part.side not in (None, *SIDES):
            raise ValueError(f"{where}: side {part.side!r} is not one of {', '.join(SIDES)}")
        if not part.joints and not part.links:
            raise ValueError(f"{where}: a part without joints needs links (its first one identifies it)")
        if part.joints & ignore:
            raise ValueError(f"{where}: lists ignored joints {sorted(part.joints & ignore)}")
        for joint in part.joints:
            if owner.setdefault(joint, part.id) != part.id:
                raise ValueError(f"{where}: joint {joint} is also in part {owner[joint]!r}")
        parts.append(part)
    ids = [p.id for p in parts]
    if len(set(ids)) != len(ids):
        raise ValueError(f"{path}: duplicate body part ids")
    return TruthBody(ignore, tuple(parts))


def load_truth(path: str | Path) -> Truth:
    """Parse and sanity-check a truth YAML file (format: ../shared/spec/evaluation.md), its ``body:``
    section included where present."""
    data = yaml.safe_load(Path(path).read_text())
    comps = tuple(_truth_component(c) for c in data["components"])
    ids = [c.id for c in comps]
    if len(set(ids)) != len(ids):
        raise ValueError(f"{path}: duplicate component ids")
    alts: list[Alternative] = []
    replaced: set[str] = set()
    for a in data.get("alternatives") or []:
        rep = tuple(a["replace"])
        if not set(rep) <= set(ids) or replaced & set(rep):
            raise ValueError(f"{path}: alternative replaces unknown or already replaced ids {rep}")
        replaced |= set(rep)
        alts.append(Alternative(rep, tuple(_truth_component(c) for c in a["with"])))
    body = _truth_body(data["body"] or {}, path) if "body" in data else None
    return Truth(data["robot"], data["urdf"], frozenset(data.get("ignore") or ()), comps, tuple(alts), body)



def load_folds(path: str | Path) -> dict[str, list[str]]:
    """The folds of a folds file (benchmarks/folds.yaml): fold name -> its robots (truth file stems)."""
    data = yaml.safe_load(Path(path).read_text())
    if not isinstance(data, dict) or not all(isinstance(v, dict) for v in data.values()):
        raise UrdfkbError(f"{path}: expected fold names mapping robots to their families")
    return {str(fold): list(robots) for fold, robots in data.items()}
