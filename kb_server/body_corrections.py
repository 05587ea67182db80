"""The edits of a robot's body a reviewer may ask for: reclassify a part, set its side, merge two parts,
split one at a joint, reject one (kb_server.corrections records them and replays them in time order).

A part is found by its joints, which re-populating keeps (by its links where it has none: a mobile
base standing for its chassis). Each edit returns the new parts and the components with the body
part they are located on, and its side, brought up to date; CorrectionError says why one does not fit.
"""
from __future__ import annotations

from dataclasses import replace

from urdfkb.kb_server.text import cut, listed
from urdfkb.pipeline.abstraction.components import SIDES, BodyPart, Component
from urdfkb.pipeline.errors import CorrectionError
from urdfkb.pipeline.knowledge.ontology import vocabulary
from urdfkb.pipeline.abstraction.stages.body import locate
from urdfkb.pipeline.reading.tree import KinematicTree

NO_SIDE = "none"
SIDE_CHOICES = (*SIDES, NO_SIDE)
Body = tuple[list[BodyPart], list[Component]]


def classes() -> tuple[str, ...]:
    """The classes a part may be given: every class below BodyPart in the ontology."""
    vocab = vocabulary()
    return vocab.subclasses_below(vocab.body_part)


def check_class(cls: str) -> str:
    if cls not in classes():
        raise CorrectionError(f"{cut(repr(cls), 100)} is not a body-part class of the ontology (one of {', '.join(classes())})")
    return cls


def check_side(side: str) -> str:
    if side not in SIDE_CHOICES:
        raise CorrectionError(f"side must be one of {', '.join(SIDE_CHOICES)}, not {cut(repr(side), 100)}")
    return side


def named(parts: list[BodyPart], name: str) -> BodyPart:
    """The part called `name` now; CorrectionError listing the robot's parts if there is none."""
    part = next((p for p in parts if p.name == name), None)
    if part is None:
        raise CorrectionError(f"no body part {cut(repr(name), 100)} on this robot "
                              f"(its parts: {listed((p.name for p in parts), 50) or 'none'})")
    return part


def find(parts: list[BodyPart], joints: tuple[str, ...], links: tuple[str, ...]) -> int:
    """The index of the part with exactly `joints` (`links` where it has no joints), else of one holding them all."""
    field, wanted = ("joint", set(joints)) if joints else ("link", set(links))
    for fits in (wanted.__eq__, wanted.issubset):
        for i, p in enumerate(parts):
            if fits(set(p.joints if joints else p.links)):
                return i
    raise CorrectionError(f"no body part with {field}{'s' if len(wanted) > 1 else ''} {listed(sorted(wanted))} any more")


def reclassify(parts: list[BodyPart], comps: list[Component], i: int, cls: str) -> Body:
    return _put(parts, i, replace(parts[i], cls=check_class(cls), confidence=1.0)), comps


def set_side(parts: list[BodyPart], comps: list[Component], i: int, side: str) -> Body:
    """The part's side (`none`: it has none), which the components located on it take."""
    part = replace(parts[i], side=None if check_side(side) == NO_SIDE else side)
    return _put(parts, i, part), [replace(c, side=part.side) if c.located_on == part.name else c for c in comps]


def touching(parts: list[BodyPart], part: BodyPart) -> list[BodyPart]:
    """The parts `part` may merge with: those hanging from one of its links, and the one it hangs from."""
    own = set(part.links)
    return [p for p in parts if p.name != part.name and (p.root in own or part.root in p.links)]


def merge(tree: KinematicTree, parts: list[BodyPart], comps: list[Component], i: int, j: int) -> Body:
    """One part of two that touch: the upper one's name, class and mount, the joints (root-most first) and
    links of both, the side either has unless they disagree; what hung from or was on either is on it."""
    a, b = parts[i], parts[j]
    if a.name == b.name:
        raise CorrectionError(f"{a.name} cannot be merged with itself")
    if b not in touching(parts, a):
        raise CorrectionError(f"{a.name} and {b.name} do not touch: one must hang from a link of the other")
    upper, lower = (a, b) if b.root in a.links else (b, a)
    sides = {upper.side, lower.side} - {None}
    merged = replace(upper, joints=_root_first(tree, upper.joints + lower.joints), confidence=1.0,
                     links=tuple(dict.fromkeys(upper.links + lower.links)), side=sides.pop() if len(sides) == 1 else None)
    kept = [merged if p.name == upper.name else replace(p, parent=merged.name) if p.parent == lower.name else p
            for p in parts if p.name != lower.name]
    return kept, [replace(c, located_on=merged.name, side=merged.side) if c.located_on in (upper.name, lower.name) else c
                  for c in comps]


def split_points(tree: KinematicTree, part: BodyPart) -> tuple[str, ...]:
    """The joints `part` may be split at: those that leave a joint or a link above them."""
    return tuple(j for j in part.joints if any(_halves(tree, part, j)[0]))


def split(tree: KinematicTree, parts: list[BodyPart], comps: list[Component], i: int, at: str,
          cls: str | None = None) -> Body:
    """Two parts of one: a new part of `cls` (default the part's own) from joint `at` down, with the links it
    moves and what is located there; the rest keeps the part's name."""
    part = parts[i]
    if at not in part.joints:
        raise CorrectionError(f"{cut(at, 100)} is not a joint of {part.name} (its joints: {listed(part.joints, 50) or 'none'})")
    (joints, links), (lower_joints, lower_links) = _halves(tree, part, at)
    if not joints and not links:
        raise CorrectionError(f"{part.name} starts at {at}: splitting there leaves nothing above it")
    new_cls = check_class(cls) if cls else part.cls
    taken = {p.name for p in parts}
    name = f"{new_cls.lower()}_{at}"
    while name in taken:
        name += "_"
    lower = BodyPart(name, new_cls, 1.0, _edge(tree, at).parent, lower_joints, lower_links, part.side, part.parent)
    moved = set(_moved(tree, at))
    return ([*parts[:i], replace(part, joints=joints, links=links, confidence=1.0), lower, *parts[i + 1:]],
            [replace(c, located_on=name) if c.located_on == part.name and c.root in moved else c for c in comps])


def reject(tree: KinematicTree, parts: list[BodyPart], comps: list[Component], i: int) -> Body:
    """The part is no part: its sub-parts go to its parent, what was on it to the nearest part above."""
    gone = parts[i]
    kept = [replace(p, parent=gone.parent) if p.parent == gone.name else p for p in parts if p.name != gone.name]
    return kept, [relocate(tree, c, kept) if c.located_on == gone.name else c for c in comps]


def relocate(tree: KinematicTree, comp: Component, parts: list[BodyPart]) -> Component:
    """`comp` located as the body pass locates it (on the part carrying its mount, with its side; else none)."""
    return locate(tree, replace(comp, located_on=None, side=None), parts)


def _halves(tree: KinematicTree, part: BodyPart, at: str) -> tuple[tuple[tuple[str, ...], tuple[str, ...]], ...]:
    """((joints, links) above joint `at`, (joints, links) from `at` down) of `part`."""
    moved = set(_moved(tree, at))
    child = {e.joint: e.child for e in tree.edges}
    below = {j for j in part.joints if child[j] in moved}
    return ((tuple(j for j in part.joints if j not in below), tuple(x for x in part.links if x not in moved)),
            (tuple(j for j in part.joints if j in below), tuple(x for x in part.links if x in moved)))


def _moved(tree: KinematicTree, joint: str) -> tuple[str, ...]:
    child = _edge(tree, joint).child
    return (child, *tree.descendants(child))


def _edge(tree: KinematicTree, joint: str):
    return next(e for e in tree.edges if e.joint == joint)


def _root_first(tree: KinematicTree, joints: tuple[str, ...]) -> tuple[str, ...]:
    """`joints` ordered by their depth in the tree, then as the URDF lists them."""
    depth = {tree.root: 0}
    for link in tree.descendants(tree.root):  # each link after its parent
        depth[link] = depth[tree.edge_to(link).parent] + 1
    order = {e.joint: (depth[e.child], k) for k, e in enumerate(tree.edges)}
    return tuple(sorted(joints, key=order.__getitem__))


def _put(parts: list[BodyPart], i: int, part: BodyPart) -> list[BodyPart]:
    return [*parts[:i], part, *parts[i + 1:]]
