"""Alike leaves (the fingers of a hand, mirrored limbs, a quadruped's legs), asked one question for all, and the
partition of items by a relation that both rest on.
"""
from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import TypeVar

from urdfkb.pipeline.reading.tree import KinematicTree
from urdfkb.pipeline.abstraction.vectors import norm

ALIKE_TOLERANCE = 1e-3  # m: joint offsets of alike chains agree to a millimetre (mirror images, copies)


def alike_leaves(tree: KinematicTree, leaves: list[str]) -> list[list[str]]:
    """`leaves` partitioned into sets of alike ones (in the order given): two leaves are alike when the chains
    from their lowest common ancestor down to each have the same shape (joint types, offset lengths, the
    leaves' own geometry and mass) and move, at least one joint of each being movable: the fingers of a
    hand, mirrored limbs, a quadruped's legs. Fixed frames side by side on one body are never alike here:
    a camera and an IMU bolted at equal distances are not the same thing."""
    paths = {leaf: tree.chain_to_root(leaf)[::-1] for leaf in leaves}
    return partition(leaves, lambda a, b: _alike(tree, paths[a], paths[b]))


def alike_sets(tree: KinematicTree, leaves: list[str], same: Callable[[str, str], bool]) -> list[list[str]]:
    """alike_leaves, each set split further where `same` (asked of two alike leaves) says their questions differ:
    the sets a stage asks one question for, the first leaf standing for all."""
    return [part for alike in alike_leaves(tree, leaves) for part in partition(alike, same)]


T = TypeVar("T")


def partition(items: Sequence[T], joined: Callable[[T, T], bool],
              apart: Callable[[T, T], bool] | None = None) -> list[list[T]]:
    """`items` in the classes of the transitive closure of `joined` (asked once for each pair of items not
    already in one class), each class in the items' order, the classes in the order of their first items.
    `apart`: two classes holding a pair it keeps apart are never joined (a pair joined through a third item
    no more than directly)."""
    parent = list(range(len(items)))
    members = [[i] for i in range(len(items))]

    def find(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for i, a in enumerate(items):
        for j, b in enumerate(items[:i]):
            ri, rj = find(i), find(j)
            if ri != rj and joined(a, b) and not (apart is not None and any(
                    apart(items[x], items[y]) for x in members[ri] for y in members[rj])):
                parent[ri] = rj
                members[rj] += members[ri]
    classes: dict[int, list[T]] = {}
    for i, item in enumerate(items):
        classes.setdefault(find(i), []).append(item)
    return list(classes.values())


def _alike(tree: KinematicTree, a: tuple[str, ...], b: tuple[str, ...]) -> bool:
    common = 0
    while common < min(len(a), len(b)) and a[common] == b[common]:
        common += 1
    below_a, below_b = a[common:], b[common:]
    if not below_a or len(below_a) != len(below_b):
        return False
    edges = [(tree.edge_to(x), tree.edge_to(y)) for x, y in zip(below_a, below_b)]
    if not any(e.movable for e, _ in edges):
        return False
    for e, f in edges:
        if e.joint_type != f.joint_type or abs(norm(e.origin.xyz) - norm(f.origin.xyz)) > ALIKE_TOLERANCE:
            return False
    facts_a, facts_b = tree.evidence.get(a[-1]), tree.evidence.get(b[-1])
    if facts_a is None or facts_b is None:
        return facts_a is facts_b
    return (facts_a.shape, round(facts_a.mass or 0.0, 3), facts_a.is_pure_frame) == \
        (facts_b.shape, round(facts_b.mass or 0.0, 3), facts_b.is_pure_frame)
