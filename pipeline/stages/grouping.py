"""Stage 4, group merging: partition the classified sub-chains into physical devices.

The model places sub-chains one at a time: each new sub-chain joins one of the devices found so
far that are near it in the tree (same mount, or sharing links with it), or starts a new device.
Every sub-chain ends in exactly one group, so the answer is a partition by construction.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

from ..oracle import Oracle
from ..prompts import NEW_DEVICE, group_question
from ..tree import KinematicTree
from .asking import Progress
from .attachment import SubChain


@dataclass
class Group:
    """Sub-chains judged to be one device, plus links absorbed by verification."""

    chains: list[SubChain]
    absorbed: list[str] = field(default_factory=list)
    confidence: float = 1.0  # the merging verdicts' shares, multiplied

    @property
    def members(self) -> list[str]:
        """Every link of the device (the root excluded), in a stable order."""
        seen = dict.fromkeys(link for c in self.chains for link in c.links)
        seen.update(dict.fromkeys(self.absorbed))
        return list(seen)

    @property
    def leaves(self) -> list[str]:
        return [c.leaf for c in self.chains]


def _near(group: Group, chain: SubChain) -> bool:
    members = set(group.members)
    return (
        any(c.root == chain.root for c in group.chains)
        or bool(members & set(chain.links))
        or chain.root in members
        or any(c.root in chain.links for c in group.chains)
    )


def _distance(tree: KinematicTree, a: SubChain, b: SubChain) -> float | None:
    if a.root != b.root:
        return None
    pa, pb = tree.position_in(a.leaf, a.root), tree.position_in(b.leaf, b.root)
    return math.dist(pa, pb)


def _evidence(tree: KinematicTree, chain: SubChain, cls: str, near: list[Group], classes: dict[str, str]) -> str:
    lines = [f" ({cls}, mounted on {chain.root})", "Devices so far:"]
    for g in near:
        d = min((x for x in (_distance(tree, chain, c) for c in g.chains) if x is not None), default=None)
        where = f", {d:.2f} m away" if d is not None else ""
        lines.append(f"- {g.leaves[0]}: frames {', '.join(g.leaves)} ({classes[g.leaves[0]]}{where})")
    return "\n".join(lines)


def merge(oracle: Oracle, tree: KinematicTree, chains: list[SubChain], classes: dict[str, str],
          kind: str, kind_label: str, progress: Progress | None = None) -> list[Group]:
    """Partition `chains` (classes: leaf → pre-class) into groups, asking about each chain in turn."""
    groups: list[Group] = []
    if progress:
        progress("group merging", 0, len(chains))
    for n, chain in enumerate(chains, 1):
        near = [g for g in groups if _near(g, chain)]
        if near:
            names = [g.leaves[0] for g in near]
            question = group_question(kind, kind_label, chain.leaf, _evidence(tree, chain, classes[chain.leaf], near, classes), names)
            (verdict,) = oracle.ask([question])
            if verdict.answer not in (None, NEW_DEVICE):
                target = near[names.index(verdict.answer)]
                target.chains.append(chain)
                target.confidence *= verdict.confidence
                chain = None
        if chain is not None:
            groups.append(Group([chain]))
        if progress:
            progress("group merging", n, len(chains))
    return groups
