"""One abstraction pass per component kind, sensors first, each condensing what it abstracted.

Data path: tree → identification → attachment roots → pre-classification → group merging →
verification → post-classification → sub-part typing → Components. After a pass, the links of
its components are removed from the tree (each device condensed onto its mount), so the next pass
sees a smaller tree and never claims a link twice.
"""
from __future__ import annotations

from typing import Callable

from .components import END_EFFECTOR, SENSOR, Component, SubComponent
from .ontology import Taxonomy
from .oracle import Oracle
from .prompts import NONE_OF_THESE
from .stages.asking import Progress
from .stages.attachment import detect_roots
from .stages.classification import Subject, Typed, descend
from .stages.grouping import Group, merge
from .stages.identification import identify
from .stages.verification import group_root, verify
from .tree import KinematicTree

# kind → (its class under Component, its branch under Subpart, how prompts name it)
PASSES = {
    SENSOR: ("Sensor", "SensorSubpart", "sensor"),
    END_EFFECTOR: ("EndEffector", "EndEffectorSubpart", "end-effector"),
}
Log = Callable[[str], None]


class Abstractor:
    """Runs the passes over one robot, keeping what identification learnt between them."""

    def __init__(self, oracle: Oracle, tax: Taxonomy, progress: Progress | None = None, log: Log | None = None):
        self.oracle, self.tax = oracle, tax
        self.progress, self.log = progress, log or (lambda _msg: None)
        self.claims: dict[str, str] = {}  # leaf → kind answer (a Component subclass or NONE_OF_THESE)

    def run(self, tree: KinematicTree) -> tuple[Component, ...]:
        components: list[Component] = []
        for kind in PASSES:
            found = self.run_pass(kind, tree, {c.root for c in components})
            components.extend(found)
            tree = tree.without({link for c in found for link in c.links})
        return tuple(components)

    def run_pass(self, kind: str, tree: KinematicTree, mounts: set[str]) -> list[Component]:
        """All components of one kind in the current tree; `mounts` carry condensed devices."""
        cls, subpart_cls, label = PASSES[kind]
        leaves = [leaf for leaf in tree.leaves() if leaf not in mounts]
        unasked = [leaf for leaf in leaves if leaf not in self.claims]
        self.claims.update(identify(self.oracle, self.tax, tree, unasked, self.progress))
        selected = [leaf for leaf in leaves if self.claims[leaf] == cls]
        if not selected:
            return []
        chains = detect_roots(self.oracle, tree, selected, label, self.progress)
        pre = descend(self.oracle, self.tax, cls, [
            Subject(f"pre:{c.leaf}", f"These links form a {label} or part of one.",
                    "Links, mount first: " + " > ".join((c.root, *c.links)))
            for c in chains
        ], "pre-classification", self.progress)
        pre_by_leaf = {c.leaf: t for c, t in zip(chains, pre)}
        groups = merge(self.oracle, tree, chains, {k: t.cls for k, t in pre_by_leaf.items()}, kind, label, self.progress)
        groups = verify(tree, groups, self._unclaimed(tree, groups, mounts), self.log)
        post = self._post_classify(tree, groups, pre_by_leaf, cls, label)
        return self._components(tree, kind, subpart_cls, label, groups, post)

    def _unclaimed(self, tree: KinematicTree, groups: list[Group], mounts: set[str]) -> Callable[[str], bool]:
        grouped = {m for g in groups for m in g.members}

        def unclaimed(link: str) -> bool:
            if link in mounts or link in grouped:
                return False
            return not tree.is_leaf(link) or self.claims.get(link) == NONE_OF_THESE
        return unclaimed

    def _post_classify(self, tree: KinematicTree, groups: list[Group], pre: dict[str, Typed], cls: str,
                       label: str) -> list[Typed]:
        """Multi-chain groups descend again given their members' classes; a lone chain keeps its class."""
        multi = [g for g in groups if len(g.chains) > 1]
        typed = descend(self.oracle, self.tax, cls, [
            Subject(f"post:{g.leaves[0]}", f"These frames form one {label} device.",
                    f"Mount: {group_root(tree, g)}\nFrames: "
                    + "; ".join(f"{leaf} ({pre[leaf].cls})" for leaf in g.leaves))
            for g in multi
        ], "post-classification", self.progress)
        by_group = {id(g): t for g, t in zip(multi, typed)}
        return [by_group.get(id(g), pre[g.leaves[0]]) for g in groups]

    def _components(self, tree: KinematicTree, kind: str, subpart_cls: str, label: str, groups: list[Group],
                    post: list[Typed]) -> list[Component]:
        """Type every member link in the Subpart branch, then assemble the components."""
        roots = [group_root(tree, g) for g in groups]
        subjects = [
            Subject(f"part:{link}", f"The link is part of a {label} device.",
                    f"Link: {link} (child of {tree.parent(link)})\n"
                    f"Device: {self.tax.label(t.cls)} on {root}, frames: {', '.join(g.leaves)}")
            for g, t, root in zip(groups, post, roots) for link in g.members
        ]
        parts = iter(descend(self.oracle, self.tax, subpart_cls, subjects, "sub-part classification", self.progress))
        return [
            Component(
                name=f"{kind}_{i}_{g.leaves[0]}",
                kind=kind,
                cls=t.cls,
                confidence=round(t.confidence, 4),
                root=root,
                subcomponents=tuple(SubComponent(link, p.cls, round(p.confidence, 4))
                                    for link, p in zip(g.members, parts)),
            )
            for i, (g, t, root) in enumerate(zip(groups, post, roots))
        ]
