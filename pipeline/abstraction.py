"""One abstraction pass per component kind, sensors first, each condensing what it abstracted.

Data path: tree → identification → attachment roots → pre-classification → group merging →
verification → post-classification → sub-part typing → Components. End-effectors skip pre- and
post-classification: after verification their extent and mount are settled from structure and their
kind inferred by a reasoner from the ontology's definitions (stages.tools, structure, reasoning); the
model is asked the kind only where the structure settles none. After a pass, the links of
its components are removed from the tree (each device condensed onto its mount), so the next pass
sees a smaller tree and never claims a link twice. Every schema fact comes from the Vocabulary
(pipeline.ontology): the kinds and their sub-part branches, the part a shape requires (a camera's
optical frame), array classes, and the sub-part classes a tool's finger chains bound.
"""
from __future__ import annotations

import json
from typing import Callable

from urdfkb.pipeline import reasoning
from urdfkb.pipeline.components import END_EFFECTOR, SENSOR, Component, FingerFact, SubComponent
from urdfkb.pipeline.evidence import LinkEvidence, named
from urdfkb.pipeline.ontology import Kind, Vocabulary
from urdfkb.pipeline.oracle import Oracle
from urdfkb.pipeline.prompts import NONE
from urdfkb.pipeline.stages import tools
from urdfkb.pipeline.stages.asking import Progress
from urdfkb.pipeline.stages.attachment import SubChain, detect_roots
from urdfkb.pipeline.stages.classification import Subject, Typed, descend
from urdfkb.pipeline.stages.grouping import Group, merge
from urdfkb.pipeline.stages.identification import identify
from urdfkb.pipeline.stages.sensor_check import coupled, drive_parts
from urdfkb.pipeline.stages.subparts import type_subparts
from urdfkb.pipeline.stages.verification import Log, group_root, indexed_units, verify
from urdfkb.pipeline.structure import ToolStructure
from urdfkb.pipeline.tree import KinematicTree

MAX_FACTS = 3  # links of a chain shown with their facts
_NO_FACTS = LinkEvidence()


class Abstractor:
    """Runs the passes over one robot, keeping what identification learnt between them."""

    def __init__(self, oracle: Oracle, tax: Vocabulary, progress: Progress | None = None, log: Log | None = None):
        self.oracle, self.tax = oracle, tax
        self.progress, self.log = progress, log or (lambda _msg: None)
        self.claims: dict[str, str] = {}  # leaf → kind answer (a Component subclass or NONE)
        self.declared = 0  # classification subjects whose options a simulator sensor declaration narrowed

    def run(self, tree: KinematicTree) -> tuple[Component, ...]:
        components: list[Component] = []
        for kind in self.tax.kinds:
            found = self.run_pass(kind, tree, {c.root for c in components})
            components.extend(found)
            tree = tree.without({link for c in found for link in c.links})
        return tuple(components)

    def run_pass(self, kind: str, tree: KinematicTree, mounts: set[str]) -> list[Component]:
        """All components of one kind in the current tree; `mounts` carry condensed devices."""
        cls = self.tax.kinds[kind].cls
        leaves = [leaf for leaf in tree.leaves() if leaf not in mounts]
        unasked = [leaf for leaf in leaves if leaf not in self.claims]
        self.claims.update(identify(self.oracle, self.tax, tree, unasked, self.progress))
        if kind == SENSOR:
            self._veto_coupled(tree, leaves)
            self._check_sensors(tree, leaves)
        selected = [leaf for leaf in leaves if self.claims[leaf] == cls]
        if not selected:
            return []
        chains = detect_roots(self.oracle, tree, selected, self.tax.kinds[kind], self._blocked(tree, cls), self.progress,
                              rigid=kind == SENSOR)
        if kind == END_EFFECTOR:
            return self._tools(tree, chains, mounts)
        pre = descend(self.oracle, self.tax, cls, [self._chain_subject(tree, c, cls) for c in chains],
                      "pre-classification", self.progress)
        pre_by_leaf = {c.leaf: t for c, t in zip(chains, pre)}
        categories = {leaf: self._category(t.cls, cls) for leaf, t in pre_by_leaf.items()}
        groups = merge(self.oracle, tree, chains, kind, categories, self.progress)
        groups = verify(tree, groups, self._unclaimed(tree, groups, mounts), self.log)
        post = self._post_classify(tree, groups, pre_by_leaf, cls)
        groups, post = self._split_units(tree, groups, post, pre_by_leaf)
        return self._components(tree, self.tax.kinds[kind], groups, post)

    def _chain_subject(self, tree: KinematicTree, chain: SubChain, cls: str) -> Subject:
        """A sub-chain to pre-classify below `cls`: its links, their facts, what a declaration rules out.

        Declared simulator sensors speak here only by narrowing the options: shown as words (type,
        plugin, ray counts) they pulled a 1.5B model off the right class (a 'depth' declaration or a
        'depth_camera' plugin towards depth camera for RGB-D and monocular cameras, ray counts
        towards lidar for sonars), while identification gains from them."""
        key = f"pre:{chain.leaf}"
        ruled_out = self._ruled_out(tree, chain.links, cls, key)
        with_facts = [link for link in reversed(chain.links) if tree.evidence.get(link, _NO_FACTS).text()][:MAX_FACTS]
        shown = [named(tree.evidence, link) if link in with_facts else link for link in chain.links]
        between = f"\nBetween it and its mount: {', '.join(shown[:-1])}" if len(shown) > 1 else ""
        return Subject(key, "The link below belongs to a {concept}.", f"Link: {shown[-1]}{between}", ruled_out)

    def _ruled_out(self, tree: KinematicTree, links, below: str, key: str) -> frozenset[str]:
        """Classes under `below` that the simulator sensors declared on `links` rule out (the
        ontology's core:simulatorSensorType alignment); each narrowing is counted and traced."""
        types = {s.type for link in links for s in tree.evidence.get(link, _NO_FACTS).sensors}
        declared = self.tax.declared_classes(types)
        ruled_out = self.tax.disagreeing(declared, below)
        if ruled_out:
            self.declared += 1
            self.log(f"{key}: declared {sorted(types)} -> {sorted(declared)}")
        return ruled_out

    def _tools(self, tree: KinematicTree, chains: list[SubChain], mounts: set[str]) -> list[Component]:
        """The end-effector pass after attachment: group, verify, settle extent and mount by structure,
        classify by the ontology's definitions (reasoner), and ask the model only what they leave open."""
        kind = self.tax.kinds[END_EFFECTOR]
        cls = kind.cls
        groups = merge(self.oracle, tree, chains, END_EFFECTOR, {}, self.progress)
        groups = verify(tree, groups, self._unclaimed(tree, groups, mounts), self.log)
        settled = tools.settle(tree, groups, lambda leaf: self.claims.get(leaf) == cls, self.log)
        groups = [g for g, _ in settled]
        structures = [s for _, s in settled]
        inferred, seconds = reasoning.classify(structures)
        self._trace({"key": "reasoner", "seconds": round(seconds, 2), "tools": [
            {"leaves": g.leaves, "facts": s.describe(), "inferred": i.cls, "thumbs": list(i.thumbs)}
            for g, s, i in zip(groups, structures, inferred)]})
        open_groups = [(g, s) for (g, s), i in zip(settled, inferred) if not i.settled]
        asked = descend(self.oracle, self.tax, cls, [
            Subject(f"post:{g.leaves[0]}", "The links below form one {concept}.",
                    f"Links: {', '.join(g.leaves)}\nStructure: {s.describe()}")
            for g, s in open_groups
        ], "end-effector classification", self.progress)
        by_group = {id(g): t for (g, _), t in zip(open_groups, asked)}
        post = [by_group.get(id(g), Typed(i.cls, 1.0)) for g, i in zip(groups, inferred)]
        fingers = [tuple(FingerFact(f.name, f.drive, self.tax.finger_chain_class(f.motion), f.name in i.thumbs,
                                    f.opposes, f.moves_with, f.mimics) for f in s.fingers)
                   for s, i in zip(structures, inferred)]
        return self._components(tree, kind, groups, post, structures, fingers)

    def _veto_coupled(self, tree: KinematicTree, leaves: list[str]) -> None:
        for leaf in coupled(tree, leaves, self._claimed(leaves), self.log):
            self.claims[leaf] = NONE

    def _check_sensors(self, tree: KinematicTree, leaves: list[str]) -> None:
        for leaf in drive_parts(self.oracle, tree, leaves, self._claimed(leaves), self.log, self.progress):
            self.claims[leaf] = NONE

    def _claimed(self, leaves: list[str]) -> set[str]:
        return {leaf for leaf in leaves if self.claims[leaf] == self.tax.kinds[SENSOR].cls}

    def _trace(self, record: dict) -> None:
        if self.oracle.trace is not None:
            self.oracle.trace.write(json.dumps(record) + "\n")

    def _category(self, cls: str, top: str) -> str:
        """The class directly under `top` that `cls` falls in (itself if it is `top`)."""
        return next((c for c in self.tax.subclasses(top) if self.tax.is_a(cls, c)), cls)

    def _blocked(self, tree: KinematicTree, cls: str) -> Callable[[str], bool]:
        """A link a device of class `cls` cannot contain: a leaf identified as another kind of component.
        (The mount of a device abstracted earlier may lie inside: a sensor on a gripper's palm.)"""
        def blocked(link: str) -> bool:
            return tree.is_leaf(link) and self.claims.get(link, NONE) not in (cls, NONE)
        return blocked

    def _unclaimed(self, tree: KinematicTree, groups: list[Group], mounts: set[str]) -> Callable[[str], bool]:
        grouped = {m for g in groups for m in g.members}

        def unclaimed(link: str) -> bool:
            if link in mounts or link in grouped:
                return False
            return not tree.is_leaf(link) or self.claims.get(link) == NONE
        return unclaimed

    def _post_classify(self, tree: KinematicTree, groups: list[Group], pre: dict[str, Typed], cls: str) -> list[Typed]:
        """Multi-chain groups descend again from what their members share; a lone chain keeps its class.

        The descent starts at the deepest class common to the members' pre-classes, or one level
        above it when that is a leaf class, so that siblings stay open (several sonar frames may
        still be one sonar, several microphones an array, colour and depth frames an RGB-D camera).
        """
        typed = {id(g): pre[g.leaves[0]] for g in groups}
        by_start: dict[str, list[Group]] = {}
        for g in groups:
            if len(g.chains) > 1:
                by_start.setdefault(self._shared_class({pre[leaf].cls for leaf in g.leaves}, cls), []).append(g)
        for start, members in by_start.items():
            results = descend(self.oracle, self.tax, start, [
                Subject(f"post:{g.leaves[0]}", "The frames below form one {concept} device.",
                        "Frames: " + "; ".join(f"{leaf} ({self.tax.label(pre[leaf].cls)})" for leaf in g.leaves),
                        self._ruled_out(tree, g.members, start, f"post:{g.leaves[0]}"))
                for g in members
            ], "post-classification", self.progress)
            typed.update({id(g): t for g, t in zip(members, results)})
        return [typed[id(g)] for g in groups]

    def _split_units(self, tree: KinematicTree, groups: list[Group], post: list[Typed],
                     pre: dict[str, Typed]) -> tuple[list[Group], list[Typed]]:
        """Numbered units of one type given one device name are separate devices unless the
        device was classified as an array (core:numberedUnits): each keeps its own pre-class."""
        out_groups, out_post = [], []
        for g, t in zip(groups, post):
            if len(g.chains) > 1 and not self.tax.has_numbered_units(t.cls) and indexed_units(tree, g):
                self.log(f"split numbered units {g.leaves} ({t.cls} is not an array)")
                out_groups += [Group([c]) for c in g.chains]
                out_post += [pre[c.leaf] for c in g.chains]
            else:
                out_groups.append(g)
                out_post.append(t)
        return out_groups, out_post

    def _shared_class(self, classes: set[str], top: str) -> str:
        """The deepest class every one of `classes` falls under (at most `top`), lifted off a leaf."""
        common = [c for c in (top, *self.tax.subclasses_below(top)) if all(self.tax.is_a(x, c) for x in classes)]
        deepest = max(common, key=lambda c: len(self.tax.ancestors(c)))
        return self.tax.parents(deepest)[0] if self.tax.is_leaf(deepest) and deepest != top else deepest

    def _components(self, tree: KinematicTree, kind: Kind, groups: list[Group],
                    post: list[Typed], structures: list[ToolStructure] | None = None,
                    fingers: list[tuple[FingerFact, ...]] | None = None) -> list[Component]:
        """Type every member link in the kind's Subpart branch, then assemble the components."""
        typed = type_subparts(self.oracle, self.tax, tree, kind, groups, post, structures, self.progress)
        return [
            Component(
                name=f"{kind.name}_{i}_{g.leaves[0]}",
                kind=kind.name,
                cls=t.cls,
                confidence=round(t.confidence, 4),
                root=group_root(tree, g),
                subcomponents=tuple(SubComponent(link, typed[link].cls, round(typed[link].confidence, 4))
                                    for link in g.members),
                fingers=fingers[i] if fingers else (),
            )
            for i, (g, t) in enumerate(zip(groups, post))
        ]
