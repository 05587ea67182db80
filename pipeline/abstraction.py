"""The abstraction passes: each a declared list of named steps (PASSES), sensors, end-effectors, then the body.

End-effectors skip pre- and post-classification: after verification their
extent and mount are settled from structure and their kind inferred by a reasoner from the
ontology's definitions (stages.tools, structure, reasoning); the model is asked the kind only where
the structure settles none. After a pass, the links of its components are removed from the tree
(each device condensed onto its mount), so the next pass sees a smaller tree and never claims a link
twice. The body pass (stages.body) then sees the whole robot again and groups the movable joints no
device owns into body parts. Every schema fact comes from the Vocabulary (pipeline.ontology);
pipeline.passes runs the steps and times them.
"""
from __future__ import annotations

import json
from dataclasses import dataclass, field, replace
from functools import partial
from typing import Callable

from urdfkb.pipeline import reasoning
from urdfkb.pipeline.components import END_EFFECTOR, SENSOR, BodyPart, Component, FingerFact, SubComponent
from urdfkb.pipeline.errors import OntologyError
from urdfkb.pipeline.evidence import LinkEvidence, named
from urdfkb.pipeline.ontology import Kind, Vocabulary
from urdfkb.pipeline.oracle import Oracle
from urdfkb.pipeline.passes import Pass, PassManager, Step, check_order
from urdfkb.pipeline.prompts import NONE, RIGID_TOOL, product_text
from urdfkb.pipeline.stages import tools
from urdfkb.pipeline.stages.asking import Progress
from urdfkb.pipeline.stages.attachment import SubChain, detect_roots, sub_chain
from urdfkb.pipeline.stages import body as body_stage
from urdfkb.pipeline.stages.classification import Subject, Typed, descend
from urdfkb.pipeline.stages.grouping import Group, merge, one_mount
from urdfkb.pipeline.stages.identification import identify, named_product
from urdfkb.pipeline.stages.sensor_check import MAJORITY, coupled, not_sensors
from urdfkb.pipeline.stages.subparts import required_parts_first, type_subparts
from urdfkb.pipeline.stages.verification import Log, group_root, indexed_units, verify
from urdfkb.pipeline.alike import alike_sets
from urdfkb.pipeline.frames import body_of, frames_of_one_body, loop_closures, viewpoints
from urdfkb.pipeline.hands import feet, hand_mounts, hands, off_limb_ends, palm
from urdfkb.pipeline.structure import ToolStructure, nothing_moves
from urdfkb.pipeline.tree import KinematicTree

MAX_FACTS = 3  # links of a chain shown with their facts
_NO_FACTS = LinkEvidence()


BODY = "body"  # the pass that finds no component kind: body parts


@dataclass
class PassState:
    """One pass over the current tree: each step reads what the steps before it left here."""

    kind: Kind | None  # the component kind the pass finds (None: the body pass)
    robot: KinematicTree  # the whole robot
    tree: KinematicTree  # what the pass sees: the robot less the devices of earlier device passes
    components: list[Component]  # every component so far; a device pass adds its own (`found`)
    leaves: list[str] = field(default_factory=list)  # the leaves this pass may claim
    chains: list[SubChain] = field(default_factory=list)  # selected leaves with their mounts
    pre: dict[str, Typed] = field(default_factory=dict)  # leaf → pre-class (sensors)
    groups: list[Group] = field(default_factory=list)  # the devices
    post: list[Typed] = field(default_factory=list)  # each device's class
    structures: list[ToolStructure] | None = None  # each tool's structure (end-effectors)
    inferred: list[reasoning.Inference] = field(default_factory=list)  # the reasoner's class per tool
    fingers: list[tuple[FingerFact, ...]] | None = None  # each tool's finger chains
    parts: dict[str, Typed] = field(default_factory=dict)  # member link → sub-part class
    found: list[Component] = field(default_factory=list)  # the devices this pass found
    candidates: list[body_stage.Chain] = field(default_factory=list)  # the body pass's candidate chains
    body: list[BodyPart] = field(default_factory=list)  # the body pass's parts
    done: bool = False  # nothing (more) to abstract: the remaining steps are skipped


class Abstractor:
    """Runs the passes over one robot, keeping what identification learnt between them."""

    def __init__(self, oracle: Oracle, tax: Vocabulary, progress: Progress | None = None, log: Log | None = None,
                 record: Callable[[dict], None] | None = None, reasoner: reasoning.Reasoner = reasoning.classify_together,
                 placer: reasoning.Placer = reasoning.placements):
        """`record` receives each step's timing record (default: the oracle's trace); `reasoner` classifies
        tools and body candidates from their facts, `placer` says which classes a body part rules out for what
        sits on it (HermiT both; tests inject stand-ins)."""
        self.oracle, self.tax, self.infer, self.place = oracle, tax, reasoner, placer
        self.progress, self.log = progress, log or (lambda _msg: None)
        self.record = record or self._trace
        self.reasoner_seconds = 0.0  # HermiT's wall time over the run
        self.body_reasoned: body_stage.Reasoned | None = None  # body candidates classified in the tools' run
        self.claims: dict[str, str] = {}  # leaf → kind answer (a Component subclass or NONE)
        self.shares: dict[str, float] = {}  # leaf → the share of identification's votes its answer had
        self.declared = 0  # classification subjects whose options a simulator sensor declaration narrowed
        self.body: tuple[BodyPart, ...] = ()  # the last run's body parts
        self.hand_tips: frozenset[str] = frozenset()  # leaves of hands and grippers: the end-effector pass's (shape step)
        self.hand_mounts: dict[str, str] = {}  # each of those leaves → its hand's mount
        self.feet: frozenset[str] = frozenset()  # limb tips the robot stands on: never tools (shape step)
        self.off_ends: frozenset[str] = frozenset()  # leaves at no limb's end: never tools (shape step)
        self.moving_feet: frozenset[str] = frozenset()  # feet that are a leg's own last link: body, unasked
        self.loop_frames: frozenset[str] = frozenset()  # frames a closed kinematic loop is cut at: no component, unasked
        self.palms: frozenset[str] = frozenset()  # the bodies of the hands found: they carry tool frames and sensors
        self.declared_sensors: frozenset[str] = frozenset()  # leaves the file declares a measuring sensor on: sensors
        if missing := [k for k in tax.kinds if k not in {p.name for p in PASSES}]:
            raise OntologyError(f"no pass declared for component kind(s) {missing} (pipeline.abstraction.PASSES)")

    def run(self, robot: KinematicTree) -> tuple[Component, ...]:
        """The robot's components (its body parts in `self.body`)."""
        components: list[Component] = []
        body: list[BodyPart] = []
        self.body_reasoned = None
        tree, manager = robot, PassManager(self.record, self._counters)
        for declared in PASSES:
            state = PassState(self.tax.kinds.get(declared.name), robot, tree, list(components))
            manager.run(declared, self, state)
            components, body = state.components, body + state.body
            tree = tree.without({link for c in state.found for link in c.links})
        self.body = tuple(body)
        return tuple(components)

    # --- steps (see PASSES) --------------------------------------------------------------------

    def shape(self, s: PassState) -> None:
        """What the robot's shape settles before any question (pipeline.hands, pipeline.frames): the leaves of hands and
        grippers (their fingers, a hand's drive, tool centre points) belong to the end-effector pass unless a
        simulator declares a sensor on them, limb tips the robot stands on are feet, never tools (a foot that moves
        on its own joint is the leg's last link: part of the body, unasked), and neither are
        leaves at no limb's end: fixed to a body a limb goes on from (along an arm, on the trunk), or bodies
        beside a hand on the link it is mounted on. Frames where a closed loop is cut (frames.loop_closures)
        are part of no component."""
        declared = {link for link, facts in s.robot.evidence.items() if facts.sensors}
        found = hands(s.robot)
        self.hand_mounts = {leaf: mount for leaf, mount in hand_mounts(found).items() if leaf not in declared}
        self.hand_tips = frozenset(self.hand_mounts)
        self.feet = feet(s.robot)
        self.moving_feet = frozenset(f for f in self.feet if s.robot.edge_to(f).movable and f not in declared)
        self.off_ends = off_limb_ends(s.robot, found)
        self.loop_frames = loop_closures(s.robot) - declared
        self.palms = frozenset(link for structure, _ in found for link in palm(s.robot, structure.fork))
        self.declared_sensors = frozenset(leaf for leaf in s.robot.leaves() if self._measures(s.robot, leaf))
        self._trace({"key": "shape", "hands": sorted(self.hand_tips), "feet": sorted(self.feet),
                     "moving_feet": sorted(self.moving_feet),
                     "off_ends": sorted(self.off_ends), "loop_frames": sorted(self.loop_frames)})

    def identification(self, s: PassState) -> None:
        mounts = {c.root for c in s.components}  # where earlier passes condensed their devices
        s.leaves = [leaf for leaf in s.tree.leaves() if leaf not in mounts]
        tools = self.tax.kinds[END_EFFECTOR].cls if END_EFFECTOR in self.tax.kinds else None
        sensors = self.tax.kinds[SENSOR].cls if SENSOR in self.tax.kinds else None
        body = self.tax.body_part  # what identification calls a leaf of the body
        body = body if body in self.tax.subclasses(self.tax.component) else NONE
        for leaf in s.leaves:
            if leaf in self.loop_frames and leaf not in self.claims:
                self.log(f"{leaf}: where a closed kinematic loop is cut (it coincides with a frame across a moving joint)")
                self.claims[leaf], self.shares[leaf] = NONE, 1.0
            elif tools and leaf in self.hand_tips and leaf not in self.claims:
                self.claims[leaf], self.shares[leaf] = tools, 1.0
            elif leaf in self.declared_sensors and leaf not in self.claims and sensors:
                self.log(f"{leaf}: the file declares a simulator sensor on it: a sensor")
                self.claims[leaf], self.shares[leaf] = sensors, 1.0
            elif leaf in self.moving_feet and leaf not in self.claims:
                self.log(f"{leaf}: a leg's last link, moving on its own joint, on the ground: part of the body")
                self.claims[leaf], self.shares[leaf] = body, 1.0
        unasked = [leaf for leaf in s.leaves if leaf not in self.claims]
        ruled = {leaf: frozenset({tools}) for leaf in unasked if tools and leaf in self.off_ends}
        for leaf, (kind, share) in identify(self.oracle, self.tax, s.tree, unasked, self.progress, self.log,
                                            ruled).items():
            if kind == tools and leaf in self.feet:  # the tip of a leg: part of the body, as the body pass will find
                self.log(f"{leaf}: a foot the robot stands on, not a tool")
                kind = body
            self.claims[leaf], self.shares[leaf] = kind, share
        self._one_kind_per_body(s)

    def _measures(self, tree: KinematicTree, leaf: str) -> bool:
        """The file declares on `leaf` a simulator sensor the ontology aligns to a sensor class other than a contact
        sensor's: a camera, ranging, inertial, force-torque... declaration is made for what measures. (A contact
        declaration also reports collisions of feet and fingertips, so those are left to the model.)"""
        if SENSOR not in self.tax.kinds:
            return False
        top, contact = self.tax.kinds[SENSOR].cls, self.tax.declared_classes(["contact"])  # SDF's sensor type
        declared = self.tax.declared_classes(s.type for s in tree.evidence.get(leaf, _NO_FACTS).sensors)
        return any(self.tax.is_a(c, top) and not any(self.tax.is_a(c, k) for k in contact) for c in declared)

    def _one_kind_per_body(self, s: PassState) -> None:
        """Frames of one body are one device (grouping binds them), so they are of one kind: where the model
        split them between the device passes' kinds, the kind with the larger sum of vote shares over them
        takes them all (a hand's leaf, known from structure, counts one). Not on a hand's palm, which carries
        its tool frames beside its sensors' frames (an IMU)."""
        devices = {self.tax.kinds[k].cls for k in (SENSOR, END_EFFECTOR) if k in self.tax.kinds}
        claimed = [leaf for leaf in s.leaves if self.claims.get(leaf) in devices]
        for frames in frames_of_one_body(s.tree, claimed):
            if len(frames) > 1 and body_of(s.tree, frames[0], frames[1]) in self.palms:
                continue  # a hand's palm carries its tool frames beside its sensors' (an IMU)
            totals: dict[str, float] = {}
            for leaf in frames:
                totals[self.claims[leaf]] = totals.get(self.claims[leaf], 0.0) + self.shares[leaf]
            if len(totals) > 1:
                kind = max(totals, key=totals.__getitem__)
                self.log(f"frames of one body {frames}: all {kind} ({', '.join(f'{k} {v:.2f}' for k, v in totals.items())})")
                for leaf in frames:
                    self.claims[leaf] = kind

    def mimic_veto(self, s: PassState) -> None:
        for leaf in coupled(s.tree, s.leaves, self._claimed(s), self.log):
            self.claims[leaf] = NONE

    def sensor_check(self, s: PassState) -> None:
        sensors = {leaf: self.shares[leaf] for leaf in self._claimed(s)}
        for leaf in not_sensors(self.oracle, s.tree, s.leaves, sensors, self.log, self.progress):
            self.claims[leaf] = NONE

    def attachment(self, s: PassState, rigid: bool = False) -> None:
        """`rigid`: devices of this kind are fixed to their mount (sensors)."""
        kind = self._kind(s)
        selected = [leaf for leaf in s.leaves if self.claims[leaf] == kind.cls]
        if not selected:
            s.done = True
            return
        settled = {} if rigid else self.hand_mounts  # a hand's leaves are mounted where its shape says
        s.chains = detect_roots(self.oracle, s.tree, selected, kind, self._blocked(s.tree, kind.cls), self.progress,
                                rigid=rigid, settled=settled)
        if rigid:  # frames of one body share one mount (grouping.one_mount)
            s.chains = one_mount(s.tree, s.chains)

    def pre_classification(self, s: PassState) -> None:
        """Each sub-chain's class below the pass's kind; alike leaves (alike.alike_leaves) whose declarations
        rule out the same classes are asked once, the first standing for all."""
        kind = self._kind(s)
        subjects = {c.leaf: self._chain_subject(s.tree, c, kind.cls) for c in s.chains}
        sets = alike_sets(s.tree, list(subjects), lambda a, b: subjects[a].exclude == subjects[b].exclude)
        typed = descend(self.oracle, self.tax, kind.cls, [subjects[leaves[0]] for leaves in sets],
                        "pre-classification", self.progress)
        by_leaf = {leaf: t for leaves, t in zip(sets, typed) for leaf in leaves}
        s.pre = {c.leaf: by_leaf[c.leaf] for c in s.chains}

    def built_in_frames(self, s: PassState) -> None:
        """A frame of a kind that devices of other kinds carry inside (Vocabulary.built_in: a lidar's or a
        camera's own IMU), alone below a housing link of its chain, is a part of the device that housing is:
        the housing is classified as a link of its own, and a sensor kind that is not built in, reached with
        the majority of the votes, becomes the chain's pre-class (the ontology spec: a device's own inertial
        frames belong to it; a bracket the model cannot place leaves the frame an IMU of its own)."""
        kind = self._kind(s)
        hosted = [c for c in s.chains if len(c.links) > 1 and self.tax.built_in(s.pre[c.leaf].cls)
                  and [link for link in s.tree.descendants(c.links[-2]) if s.tree.is_leaf(link)] == [c.leaf]]
        if not hosted:
            return
        housings = [SubChain(c.links[-2], c.root, c.links[:-1]) for c in hosted]
        typed = descend(self.oracle, self.tax, kind.cls, [self._chain_subject(s.tree, h, kind.cls) for h in housings],
                        "pre-classification", self.progress)
        for c, h, t in zip(hosted, housings, typed):
            if t.cls != kind.cls and not self.tax.built_in(t.cls) and t.confidence > MAJORITY:
                self.log(f"pre:{c.leaf}: the built-in {self.tax.label(s.pre[c.leaf].cls)} of {h.leaf}, a {t.cls}")
                s.pre[c.leaf] = t

    def group_merging(self, s: PassState) -> None:
        kind = self._kind(s)
        categories = {leaf: self._category(t.cls, kind.cls) for leaf, t in s.pre.items()}
        s.groups = merge(self.oracle, s.tree, s.chains, kind.name, categories, self.progress)

    def verification(self, s: PassState) -> None:
        s.groups = verify(s.tree, s.groups, self._unclaimed(s.tree, s.groups, {c.root for c in s.components}), self.log)

    def post_classification(self, s: PassState) -> None:
        """Multi-chain groups descend again from what their members share; a lone chain keeps its class,
        unless where its frames see from rules that class out (below).

        The descent starts at the deepest class common to the members' pre-classes, or one level
        above it when that is a leaf class, so that siblings stay open (several sonar frames may
        still be one sonar, several microphones an array, colour and depth frames an RGB-D camera).
        Where a device's optical frames see from (frames.viewpoints) rules classes out by the
        ontology's core:viewpointCount definitions (a monocular camera sees from one place, a stereo camera
        from two), they are not offered; a lone chain's pre-class so ruled out descends again from its parent.
        Nor are the classes the number of its sensing frames rules out (core:elementCount: a tactile sensor is
        one pad, a microphone one capsule; several read as one device are an array).
        """
        top = self._kind(s).cls
        typed = {id(g): s.pre[g.leaves[0]] for g in s.groups}
        by_start: dict[str, list[Group]] = {}
        views = {id(g): viewpoints(s.tree, g.leaves) for g in s.groups}
        counted_out = {id(g): self.tax.unseen(views[id(g)], top) | self.tax.miscounted(len(g.chains), top)
                       for g in s.groups}  # by where its frames see from, and by how many there are
        for g in s.groups:
            if len(g.chains) > 1:
                by_start.setdefault(self._shared_class({s.pre[leaf].cls for leaf in g.leaves}, top), []).append(g)
            elif (cls := s.pre[g.leaves[0]].cls) in counted_out[id(g)]:
                self.log(f"post:{g.leaves[0]}: its frames see from {views[id(g)]} place(s), so it is no {cls}")
                by_start.setdefault(self.tax.parents(cls)[0], []).append(g)
        for start, members in by_start.items():
            unfit = self._frames_first(s, [g for g in members if len(g.chains) > 1], start)
            results = descend(self.oracle, self.tax, start, [
                Subject(f"post:{g.leaves[0]}", "The frames below form one {concept} device.",
                        "Frames: " + "; ".join(f"{leaf} ({self.tax.label(s.pre[leaf].cls)})" for leaf in g.leaves),
                        self._ruled_out(s.tree, g.members, start, f"post:{g.leaves[0]}") | counted_out[id(g)]
                        | unfit.get(id(g), frozenset()))
                for g in members
            ], "post-classification", self.progress)
            typed.update({id(g): t for g, t in zip(members, results)})
        s.post = [typed[id(g)] for g in s.groups]

    def _frames_first(self, s: PassState, groups: list[Group], start: str) -> dict[int, frozenset[str]]:
        """The frames say the device: the part a `start` device requires (a camera's optical frame) is typed at
        each leaf of `groups` first (into `s.parts`), and each group is not offered the classes under `start`
        that the ontology says such parts rule out (Vocabulary.unfit: colour and depth frames make an RGB-D
        camera, a depth frame no monocular camera). Only for devices of several frames: a lone link may stand
        for a whole camera (a RealSense written as one link), and its one answer cannot show colour and depth
        together (asked of lone frames too, eval r14g, Centauro's and G1's D435s came out monocular)."""
        if not groups:
            return {}
        leaves = [leaf for g in groups for leaf in g.leaves]
        frames = required_parts_first(self.oracle, self.tax, s.tree, leaves, start, self.progress)
        if not frames:
            return {}
        s.parts.update(frames)
        unfit = {}
        for g in groups:
            kinds = frozenset(frames[leaf].cls for leaf in g.leaves)
            unfit[id(g)] = self.tax.unfit(kinds, start)
            if unfit[id(g)]:
                self.log(f"post:{g.leaves[0]}: frames {sorted(kinds)}, so no {', '.join(sorted(unfit[id(g)]))}")
        return unfit

    def numbered_units(self, s: PassState) -> None:
        """Numbered units of one type given one device name are separate devices unless the
        device was classified as an array (core:numberedUnits): each keeps its own pre-class."""
        groups, post = [], []
        for g, t in zip(s.groups, s.post):
            if len(g.chains) > 1 and not self.tax.has_numbered_units(t.cls) and indexed_units(s.tree, g):
                self.log(f"split numbered units {g.leaves} ({t.cls} is not an array)")
                groups += [Group([c]) for c in g.chains]
                post += [s.pre[c.leaf] for c in g.chains]
            else:
                groups.append(g)
                post.append(t)
        s.groups, s.post = groups, post

    def tool_extent(self, s: PassState) -> None:
        cls = self._kind(s).cls
        settled = tools.settle(s.tree, s.groups, lambda leaf: self.claims.get(leaf) == cls, self.log)
        s.groups = [g for g, _ in settled]
        s.structures = [structure for _, structure in settled]

    def reasoner(self, s: PassState) -> None:
        """Each tool's class from the ontology's definitions over its structure, and its finger chains.

        The body pass's candidates are known here already (the tools' links and mounts are settled; only
        their classes are not), so where a tool has finger chains (HermiT runs anyway) the one run also
        classifies those, each tool standing as its own individual among the devices; the body pass
        takes those classes where its facts come out the same (every tool on a candidate settled by
        this run), else runs the reasoner itself. A JVM with HermiT costs 2.5-4 s."""
        structures = s.structures or []
        parts = self._body_facts(s) if any(t.fingers for t in structures) else []
        if parts:
            s.inferred, classes, seconds = self.infer(structures, parts)
            self.body_reasoned = ([replace(f, devices=tuple(self._settled(d, s.inferred) for d in f.devices))
                                   for f in parts], classes)
        else:
            s.inferred, seconds = reasoning.classify(structures, self.infer)
        self.reasoner_seconds += seconds
        self._trace({"key": "reasoner", "seconds": round(seconds, 2), "tools": [
            {"leaves": g.leaves, "facts": st.describe(), "inferred": i.cls, "thumbs": list(i.thumbs)}
            for g, st, i in zip(s.groups, structures, s.inferred)]})
        s.fingers = [tuple(FingerFact(f.name, f.drive, self.tax.finger_chain_class(f.motion), f.name in i.thumbs,
                                      f.opposes, f.moves_with, f.mimics) for f in st.fingers)
                     for st, i in zip(structures, s.inferred)]

    def tool_classification(self, s: PassState) -> None:
        """The model is asked the kind of the tools whose structure settles none, seeing what each is mounted
        on (a fingerless tool on a link whose mesh is a hand is a hand). A tool in which nothing moves
        (structure.nothing_moves) may also stay a plain end effector (prompts.RIGID_TOOL: a probe, a ball), which the
        ontology allows and no kind below it fits."""
        open_groups = [(g, st) for g, st, i in zip(s.groups, s.structures or [], s.inferred) if not i.settled]
        asked = descend(self.oracle, self.tax, self._kind(s).cls, [
            Subject(f"post:{g.leaves[0]}", "The links below form one {concept}.",
                    f"Links: {', '.join(g.leaves)}\nOn: {named(s.tree.evidence, self._mount(s.tree, g))}"
                    f"\nStructure: {st.describe()}",
                    stay=RIGID_TOOL if nothing_moves(s.tree, st, self._mount(s.tree, g)) else None)
            for g, st in open_groups
        ], "end-effector classification", self.progress)
        by_group = {id(g): t for (g, _), t in zip(open_groups, asked)}
        s.post = [by_group.get(id(g), Typed(i.cls, 1.0)) for g, i in zip(s.groups, s.inferred)]

    def subpart_typing(self, s: PassState) -> None:
        s.parts = type_subparts(self.oracle, self.tax, s.tree, self._kind(s), s.groups, s.post, s.structures,
                                self.progress, s.parts)

    def assembly(self, s: PassState) -> None:
        s.found = [self._device(s, i, g, t, s.parts) for i, (g, t) in enumerate(zip(s.groups, s.post))]
        s.components += s.found

    def device_joints(self, s: PassState) -> None:
        s.components = body_stage.with_joints(s.robot, s.components)

    def body_candidates(self, s: PassState) -> None:
        s.candidates = body_stage.candidates(s.robot, s.components)
        s.done = not s.candidates

    def body_classification(self, s: PassState) -> None:
        body_stage.classify(self.oracle, self.tax, s.robot, s.candidates, s.components, self.progress, self.log,
                            self._reasoned, self.body_reasoned, self.infer)

    def body_assembly(self, s: PassState) -> None:
        s.body = body_stage.assemble(self.tax, s.robot, s.candidates)

    def sides(self, s: PassState) -> None:
        s.body = body_stage.sides(self.oracle, s.robot, s.body, self.progress, self.log)

    def location(self, s: PassState) -> None:
        s.components = [body_stage.locate(s.robot, c, s.body) for c in s.components]

    def placement(self, s: PassState) -> None:
        """The property-restriction loop: a component whose class says where it may sit (Vocabulary.placement:
        a bumper on a mobile base or a leg) is checked by the reasoner against the body part it is located on;
        where its class is inconsistent with that part, it is asked its class question again from its kind
        down, without the classes the part rules out, and the trace records the restriction that fired.
        The question is its sub-chain's pre-classification (a device of several frames: its frames together),
        so only the options change. Its sub-parts stay as typed: a new class that requires other parts is
        held back for review by the shapes (pipeline.screen)."""
        sits = {p.name: p.cls for p in s.body}
        checked = [(c, sits[c.located_on]) for c in s.components if c.located_on is not None and self.tax.placement(c.cls)]
        if not checked:
            return
        placed = tuple(c for kind in self.tax.kinds.values() for c in self.tax.subclasses_below(kind.cls)
                       if self.tax.placement(c))
        ruled, seconds = self.place(self.tax.body_classes, placed)
        self.reasoner_seconds += seconds
        for comp, part in [(c, part) for c, part in checked if c.cls in ruled[part]]:
            (typed,) = descend(self.oracle, self.tax, self.tax.kinds[comp.kind].cls,
                               [self._class_question(s.robot, comp, ruled[part])], "placement", self.progress)
            restriction = self.tax.placement(comp.cls)
            self.log(f"placement: {comp.name} is no {comp.cls} on a {part} ({restriction}): asked again, {typed.cls}")
            self._trace({"key": "placement", "component": comp.name, "class": comp.cls, "located_on": comp.located_on,
                         "part_class": part, "restriction": restriction, "reasked": typed.cls,
                         "confidence": round(typed.confidence, 4)})
            s.components = [replace(c, cls=typed.cls, confidence=round(typed.confidence, 4)) if c is comp else c
                            for c in s.components]

    # --- helpers ----------------------------------------------------------------------------------

    def _kind(self, s: PassState) -> Kind:
        if s.kind is None:
            raise ValueError("a step of the device passes ran in a pass that finds no component kind")
        return s.kind

    def _class_question(self, tree: KinematicTree, comp: Component, excluded: frozenset[str]) -> Subject:
        """A device's class question without `excluded`: its one leaf's pre-classification, or its frames together."""
        leaves = [link for link in comp.links if tree.is_leaf(link)] or list(comp.links)
        if len(leaves) == 1:
            asked = self._chain_subject(tree, sub_chain(tree, leaves[0], comp.root), self.tax.kinds[comp.kind].cls)
            return replace(asked, key=f"placement:{leaves[0]}", exclude=asked.exclude | excluded)
        return Subject(f"placement:{leaves[0]}", "The frames below form one {concept} device.",
                       "Frames: " + "; ".join(named(tree.evidence, leaf) for leaf in leaves), excluded)

    @staticmethod
    def _mount(tree: KinematicTree, group: Group) -> str:
        """The one link carrying a verified group (verification splits a group with several)."""
        root = group_root(tree, group)
        if root is None:
            raise ValueError(f"the group of {group.leaves} has several mounts after verification")
        return root

    def _body_facts(self, s: PassState) -> list[reasoning.PartFacts]:
        """The body pass's candidates' facts, with this pass's tools as assembly will make them but for
        their classes: tool i's class is reasoning.TOOL_REF + i."""
        tools = [self._device(s, i, g, Typed(f"{reasoning.TOOL_REF}{i}", 0.0)) for i, g in enumerate(s.groups)]
        components = body_stage.with_joints(s.robot, s.components + tools)
        found = body_stage.candidates(s.robot, components)
        return body_stage.findings(s.robot, found, components).facts if found else []

    def _device(self, s: PassState, i: int, g: Group, t: Typed, parts: dict[str, Typed] | None = None) -> Component:
        """The pass's i-th device, group `g` classified `t`; each link typed by `parts` (None: left untyped). Its
        confidence is that of its class times that of its kind: the mean share of the votes by which its leaves were
        identified as this kind (1 where the shape or a declaration decided, as the class is 1 where the reasoner
        did), so a device structure settles on leaves the model hardly took for it still goes to review."""
        kind = self._kind(s)
        links = [parts[link] if parts is not None else Typed("", 0.0) for link in g.members]
        of_kind = sum(self.shares.get(leaf, 1.0) for leaf in g.leaves) / len(g.leaves)
        return Component(
            name=f"{kind.name}_{i}_{g.leaves[0]}",
            kind=kind.name,
            cls=t.cls,
            confidence=round(t.confidence * of_kind, 4),
            root=self._mount(s.tree, g),
            subcomponents=tuple(SubComponent(link, p.cls, round(p.confidence, 4)) for link, p in zip(g.members, links)),
            fingers=s.fingers[i] if s.fingers else (),
        )

    @staticmethod
    def _settled(device: str, inferred: list[reasoning.Inference]) -> str:
        """A device as the body pass will see it: a tool the run settled by its inferred class; a tool left
        open by a name no class has (the model decides it later, so those facts never match)."""
        if not device.startswith(reasoning.TOOL_REF):
            return device
        inference = inferred[int(device[len(reasoning.TOOL_REF):])]
        return inference.cls if inference.settled else f"{device} (open)"

    def _claimed(self, s: PassState) -> set[str]:
        """The pass's leaves identified as its kind."""
        return {leaf for leaf in s.leaves if self.claims[leaf] == self._kind(s).cls}

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
        product = product_text(self.tax, named_product(tree, list(reversed(chain.links))), cls)
        return Subject(key, "The link below belongs to a {concept}.", f"Link: {shown[-1]}{between}{product}", ruled_out)

    def _ruled_out(self, tree: KinematicTree, links, below: str, key: str) -> frozenset[str]:
        """Classes under `below` that the simulator sensors declared on `links` rule out: by their type (the
        ontology's core:simulatorSensorType alignment) and by the span a ray sensor sweeps
        (core:horizontalFieldOfViewRadians restrictions: a 10-degree beam is no lidar); each narrowing is
        counted and traced."""
        sensors = [s for link in links for s in tree.evidence.get(link, _NO_FACTS).sensors]
        types = {s.type for s in sensors}
        declared = self.tax.declared_classes(types)
        ruled_out = self.tax.disagreeing(declared, below)
        spans = [s.fov for s in sensors if s.fov is not None and s.samples is not None]  # ray sensors' sweeps
        narrow = self.tax.too_narrow(max(spans), below) - ruled_out if spans else frozenset()
        if ruled_out or narrow:
            self.declared += 1
            self.log(f"{key}: declared {sorted(types)} -> {sorted(declared)}"
                     + (f"; sweeping {max(spans):.2f} rad, not {sorted(narrow)}" if narrow else ""))
        return ruled_out | narrow

    def _counters(self) -> dict[str, float]:
        """Running totals of the work a step does, for its timing record (pipeline.timings)."""
        stats = self.oracle.stats
        return {"model_seconds": self.oracle.seconds, "tokens": stats.prompt_tokens,
                "restored_tokens": stats.restored_tokens, "decodes": stats.calls,
                "reasoner_seconds": self.reasoner_seconds}

    def _reasoned(self, seconds: float) -> None:
        self.reasoner_seconds += seconds

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

    def _shared_class(self, classes: set[str], top: str) -> str:
        """The deepest class every one of `classes` falls under (at most `top`), lifted off a leaf."""
        common = [c for c in (top, *self.tax.subclasses_below(top)) if all(self.tax.is_a(x, c) for x in classes)]
        deepest = max(common, key=lambda c: len(self.tax.ancestors(c)))
        return self.tax.parents(deepest)[0] if self.tax.is_leaf(deepest) and deepest != top else deepest


SENSOR_PASS = Pass(SENSOR, (
    Step("shape", Abstractor.shape, ("robot",), ("hands", "feet", "limb ends", "loops", "palms")),
    Step("identification", Abstractor.identification,
         ("tree", "components", "hands", "feet", "limb ends", "loops", "palms"), ("leaves", "claims")),
    Step("mimic veto", Abstractor.mimic_veto, ("leaves", "claims"), ("claims",)),
    Step("sensor check", Abstractor.sensor_check, ("leaves", "claims"), ("claims",)),
    Step("attachment", partial(Abstractor.attachment, rigid=True), ("leaves", "claims"), ("chains",)),
    Step("pre-classification", Abstractor.pre_classification, ("chains",), ("pre",)),
    Step("built-in frames", Abstractor.built_in_frames, ("chains", "pre"), ("pre",)),
    Step("group merging", Abstractor.group_merging, ("chains", "pre"), ("groups",)),
    Step("verification", Abstractor.verification, ("groups", "claims"), ("groups",)),
    Step("post-classification", Abstractor.post_classification, ("groups", "pre"), ("post", "parts")),
    Step("numbered units", Abstractor.numbered_units, ("groups", "pre", "post"), ("groups", "post")),
    Step("sub-part typing", Abstractor.subpart_typing, ("groups", "post", "parts"), ("parts",)),
    Step("assembly", Abstractor.assembly, ("groups", "post", "parts"), ("found", "components")),
))

END_EFFECTOR_PASS = Pass(END_EFFECTOR, (
    Step("identification", Abstractor.identification,
         ("tree", "components", "hands", "feet", "limb ends", "loops", "palms"), ("leaves", "claims")),
    Step("attachment", Abstractor.attachment, ("leaves", "claims"), ("chains",)),
    Step("group merging", Abstractor.group_merging, ("chains",), ("groups",)),
    Step("verification", Abstractor.verification, ("groups", "claims"), ("groups",)),
    Step("tool extent", Abstractor.tool_extent, ("groups", "claims"), ("groups", "structures")),
    Step("reasoner", Abstractor.reasoner, ("groups", "structures", "components"), ("inferred", "fingers")),
    Step("end-effector classification", Abstractor.tool_classification, ("groups", "structures", "inferred"),
         ("post",)),
    Step("sub-part typing", Abstractor.subpart_typing, ("groups", "post", "structures"), ("parts",)),
    Step("assembly", Abstractor.assembly, ("groups", "post", "parts", "fingers"), ("found", "components")),
))

BODY_PASS = Pass(BODY, (
    Step("device joints", Abstractor.device_joints, ("robot", "components"), ("components",)),
    Step("candidates", Abstractor.body_candidates, ("robot", "components"), ("candidates",)),
    Step("body classification", Abstractor.body_classification, ("candidates", "components"), ("candidates",)),
    Step("assembly", Abstractor.body_assembly, ("candidates",), ("body",)),
    Step("sides", Abstractor.sides, ("body",), ("body",)),
    Step("location", Abstractor.location, ("body", "components"), ("components",)),
    Step("placement", Abstractor.placement, ("body", "components"), ("components",)),
))

# Run in this order; a device pass is named by the core:componentKind of the components it finds, and
# removes them from the tree the next device pass sees.
PASSES = (SENSOR_PASS, END_EFFECTOR_PASS, BODY_PASS)
check_order(PASSES, given=("robot", "tree", "components"))  # what each pass's state starts with
