"""Classify candidate tools from their structural facts with the ontology's class definitions (HermiT).

Each tool becomes an EndEffector individual in a temporary world holding the core ontology, with
one individual per finger chain typed by its drive's motion (the class the ontology aligns to it by
`core:fingerDrive`), `opposes`, `movesWith` and `isMimicOf` between chains.
The code closes what it knows (the tool has no chain but these, each opposes and moves with no chain
but those: an at-most cardinality equal to the count of asserted, all-different chains), so the qualified
cardinalities in the definitions of `ParallelGripper`,
`MultiFingerGripper`, `AnthropomorphicHand` and `ThumbChain` apply. One reasoner run covers every
tool of a robot pass, and with them the body pass's candidate parts (classify_together): starting the
JVM is most of a run's time. A tool without finger chains is left to the model: the URDF does not say
whether a rigid tool holds by suction, a magnet, or fingers written as fixed links.
Candidate body parts (PartFacts) are classified by the BodyPart classes' sufficient conditions.
`placements` says which component classes a body part rules out for what sits on it (the ontology's
∀isLocatedOn restrictions: a bumper sits on a mobile base or a leg).
"""
from __future__ import annotations

import logging
import time
from dataclasses import dataclass
from typing import Callable

from urdfkb.pipeline.abstraction import components

from urdfkb.pipeline.knowledge import rdf
from urdfkb.pipeline.knowledge.namespaces import CORE_IRI
from urdfkb.pipeline.knowledge.ontology import load_core, vocabulary
from urdfkb.pipeline.abstraction.structure import ToolStructure

log = logging.getLogger(__name__)
THUMB = "ThumbChain"


def _tool_class() -> str:
    """The end-effector kind's class: what a tool is when its facts settle nothing finer."""
    return vocabulary().kinds[components.END_EFFECTOR].cls


@dataclass(frozen=True)
class Inference:
    """What the reasoner concluded about one tool: its deepest class under EndEffector (EndEffector
    itself when the facts settle nothing) and its chains inferred to be thumbs."""

    cls: str
    thumbs: tuple[str, ...]

    @property
    def settled(self) -> bool:
        return self.cls != _tool_class()


def classify(tools: list[ToolStructure], reasoner: Reasoner | None = None) -> tuple[list[Inference], float]:
    """One Inference per tool, and the reasoner's wall time in seconds (0 when nothing needed it)."""
    if not any(t.fingers for t in tools):
        return [Inference(_tool_class(), ()) for _ in tools], 0.0
    inferred, _, seconds = (reasoner or classify_together)(tools, [])
    return inferred, seconds


def classify_together(tools: list[ToolStructure], parts: list["PartFacts"]) -> tuple[list[Inference], list[str | None], float]:
    """Tools and candidate body parts in one reasoner run (one JVM): each tool's Inference, each part's
    class (see classify_parts) and the wall time. A part's device named TOOL_REF + i is the i-th tool's
    own individual, whatever class the run infers for it."""
    world = rdf.new_world()
    try:
        core = load_core(world)
        onto = world.get_ontology("urn:urdfkb:reasoning#")
        with onto:
            tool_individuals = _assert_tools(core, tools)
            part_individuals = _assert_parts(core, parts, [individual for individual, _ in tool_individuals])
        what = " and ".join(w for w, there in (("end-effector kinds", tools), ("body parts", parts)) if there)
        ran, seconds = _hermit(world, f"{what} are")
        if not ran:
            return [Inference(_tool_class(), ()) for _ in tools], [None] * len(parts), seconds
        return ([_inference(individual, chains) for individual, chains in tool_individuals],
                [_part_class(part) for part in part_individuals], seconds)
    finally:
        world.close()


def _assert_tools(core, tools: list[ToolStructure]) -> list[tuple[object, dict]]:
    """Each tool as an EndEffector individual with its finger chains, closed as the definitions need."""
    individuals: list[tuple[object, dict]] = []
    chains_all: list[object] = []
    for i, tool in enumerate(tools):
        individual = core.EndEffector(f"tool{i}")
        chains = {f.name: core[vocabulary().finger_chain_class(f.motion)](f"tool{i}_{j}")
                  for j, f in enumerate(tool.fingers)}
        for finger in tool.fingers:
            chain = chains[finger.name]
            chain.opposes = [chains[o] for o in finger.opposes]
            chain.movesWith = [chains[o] for o in finger.moves_with]
            chain.is_a.append(core.opposes.max(len(finger.opposes), core.FingerChain))
            chain.is_a.append(core.movesWith.max(len(finger.moves_with), core.FingerChain))
            if finger.mimics:
                chain.isMimicOf = [chains[finger.mimics]]
        if chains:
            individual.hasFingerChain = list(chains.values())
            individual.is_a.append(core.hasFingerChain.max(len(chains), core.FingerChain))
        chains_all.extend(chains.values())
        individuals.append((individual, chains))
    if len(chains_all) > 1:
        rdf.all_different(chains_all)
    return individuals


def _hermit(world: rdf.World, left: str) -> tuple[bool, float]:
    """Run HermiT over `world`: (whether it ran, its wall time). Without Java, or when HermiT fails, what
    it would have settled (`left`, e.g. "body parts are") is left to the model."""
    started = time.monotonic()
    if (failure := rdf.hermit(world)) is not None:
        log.warning("reasoner unavailable (%s): %s left to the model", failure, left)
        return False, time.monotonic() - started
    return True, time.monotonic() - started


def _inference(individual, chains: dict) -> Inference:
    vocab, tool = vocabulary(), _tool_class()
    names = [iri[len(CORE_IRI):] for iri in rdf.class_iris(individual) if iri.startswith(CORE_IRI)]
    under = [n for n in names if n in vocab and vocab.is_a(n, tool)]
    cls = max(under, key=lambda n: len(vocab.ancestors(n)), default=tool)
    thumbs = tuple(name for name, chain in chains.items()
                   if any(getattr(c, "iri", "") == CORE_IRI + THUMB for c in chain.is_a))
    return Inference(cls, thumbs)


@dataclass(frozen=True)
class PartFacts:
    """What the code asserts of one candidate body part (pipeline.abstraction.stages.body): the URDF types of its
    joints, the classes of the devices on its links, the candidates hanging from them (by index), whether it
    reaches the ground, the side it lies on, its class where already settled, how far out the devices on it lie, and
    whether all its joints turn about the vertical, or all slide."""

    joint_types: tuple[str, ...]
    devices: tuple[str, ...]
    carries: tuple[int, ...]
    reaches_ground: bool
    side: str | None = None   # "left"/"right": the side of the root's x-z plane its joints lie on (None: across it)
    known: str | None = None  # its class where already settled (the model's, in a second round): asserted
    span: float = 0.0         # m: from its first joint to the farthest link of the devices on it, at the zero pose
    vertical: bool = False    # every joint of it turns about an axis within 30 degrees of the vertical, at rest
    sliding: bool = False     # every joint of it slides (prismatic)


# classify_together's contract: HermiT by default; Abstractor and runner.run take another, as tests inject a
# stand-in that needs no JVM (tests/scripted_reasoner.py), the way they inject a scripted model backend.
Reasoner = Callable[[list[ToolStructure], list[PartFacts]], tuple[list[Inference], list[str | None], float]]


def classify_parts(parts: list[PartFacts], reasoner: Reasoner | None = None) -> tuple[list[str | None], float]:
    """Each candidate's BodyPart class inferred from the ontology's sufficient conditions (None where
    they settle none, or settle two), and the reasoner's wall time (0 when nothing needed it)."""
    if not parts:
        return [], 0.0
    _, inferred, seconds = (reasoner or classify_together)([], parts)
    return inferred, seconds


TOOL_REF = "tool:"  # a device of a body part that is the tool of that index in the same reasoner run


def _assert_parts(core, parts: list[PartFacts], tools: list) -> list:
    """Each candidate as a BodyPart individual with the facts the code asserts of it."""
    vocab, tool = vocabulary(), _tool_class()
    individuals = [core[vocab.body_part](f"part{i}") for i in range(len(parts))]
    tools_on = [sum(cls.startswith(TOOL_REF) or vocab.is_a(cls, tool) for cls in facts.devices) for facts in parts]
    for i, (facts, part) in enumerate(zip(parts, individuals)):
        part.hasJoint = [core[vocab.joint_class(t)](f"part{i}_joint{j}") for j, t in enumerate(facts.joint_types)]
        part.carriesDevice = [tools[int(cls[len(TOOL_REF):])] if cls.startswith(TOOL_REF) else core[cls](f"part{i}_device{j}")
                              for j, cls in enumerate(facts.devices)]
        part.carriesPart = [individuals[k] for k in facts.carries]
        part.reachesGround = facts.reaches_ground
        if facts.side is not None:
            part.side = facts.side
        if facts.known is not None:
            part.is_a.append(core[facts.known])
        # what the conditions count is asserted as counts: no closure, no cardinality reasoning
        part.jointCount, part.partCount = len(facts.joint_types), len(facts.carries)
        part.deviceCount, part.endEffectorCount = len(facts.devices), tools_on[i]
        part.toolPartCount = sum(tools_on[k] > 0 for k in facts.carries)
        part.deviceSpanMetres = round(facts.span, 3)
        part.turnsAboutVertical = facts.vertical
        part.slidesOnly = facts.sliding
    return individuals


# placements' contract: HermiT by default; Abstractor and runner.run take another (tests/scripted_reasoner.py).
Placer = Callable[[tuple[str, ...], tuple[str, ...]], tuple[dict[str, frozenset[str]], float]]
_PLACEMENTS: dict[tuple[tuple[str, ...], tuple[str, ...]], dict[str, frozenset[str]]] = {}


def placements(parts: tuple[str, ...], classes: tuple[str, ...]) -> tuple[dict[str, frozenset[str]], float]:
    """For each body-part class of `parts`, the `classes` a component located on such a part cannot be, and
    the reasoner's wall time: one individual located on a part of each class, and for each class C a class
    defined as ¬C; HermiT places the individual in ¬C where being a C is inconsistent with where it sits.
    The answer depends on the ontology alone, so a process asks HermiT once (later calls take 0 s); without
    Java nothing is ruled out."""
    key = (parts, classes)
    if key in _PLACEMENTS:
        return _PLACEMENTS[key], 0.0
    world = rdf.new_world()
    try:
        core = load_core(world)
        onto = world.get_ontology("urn:urdfkb:placement#")
        with onto:
            located = {}
            for i, part in enumerate(parts):  # a component of no known kind on a part of each class
                located[part] = core[vocabulary().component](f"on{i}")
                located[part].isLocatedOn = core[part](f"part{i}")  # a functional property: one value
            negations = {cls: rdf.complement_class(f"not{i}", core[cls]) for i, cls in enumerate(classes)}
        ran, seconds = _hermit(world, "placements are")
        if not ran:
            return {part: frozenset() for part in parts}, seconds
        table = {part: frozenset(cls for cls, negation in negations.items() if negation in rdf.class_iris(individual))
                 for part, individual in located.items()}
    finally:
        world.close()
    _PLACEMENTS[key] = table
    return table, seconds


def _part_class(part) -> str | None:
    body = vocabulary().body_classes
    classes = {iri[len(CORE_IRI):] for iri in rdf.class_iris(part)}
    settled = [c for c in body if c in classes]
    return settled[0] if len(settled) == 1 else None
