"""Classify candidate tools from their structural facts with the ontology's class definitions (HermiT).

Each tool becomes an EndEffector individual in a temporary world holding the core ontology, with
one individual per finger chain typed by its drive's motion (the class the ontology aligns to it by
`core:fingerDrive`), `opposes`, `movesWith` and `isMimicOf` between chains.
The code closes what it knows (the tool has no chain but these, each opposes and moves with no chain
but those: an at-most cardinality equal to the count of asserted, all-different chains, which
HermiT classifies faster than the same closure with nominals), so the qualified cardinalities in the definitions of `ParallelGripper`,
`MultiFingerGripper`, `AnthropomorphicHand` and `ThumbChain` apply. One reasoner run covers every
tool of a robot pass. A tool without finger chains is left to the model: the URDF does not say
whether a rigid tool holds by suction, a magnet, or fingers written as fixed links.
"""
from __future__ import annotations

import logging
import time
from dataclasses import dataclass

import owlready2

from urdfkb.pipeline import components
from urdfkb.pipeline.ontology import CORE_IRI, load_core, vocabulary
from urdfkb.pipeline.structure import ToolStructure

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


def classify(tools: list[ToolStructure]) -> tuple[list[Inference], float]:
    """One Inference per tool, and the reasoner's wall time in seconds (0 when nothing needed it)."""
    if not any(t.fingers for t in tools):
        return [Inference(_tool_class(), ()) for _ in tools], 0.0
    world = owlready2.World()
    try:
        core = load_core(world)
        onto = world.get_ontology("urn:urdfkb:tools#")
        individuals = []
        with onto:
            chains_all = []
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
                owlready2.AllDifferent(chains_all)
        started = time.monotonic()
        try:
            owlready2.sync_reasoner_hermit(world, infer_property_values=False, debug=0)
        except (owlready2.OwlReadyJavaError, OSError) as e:  # no Java, or HermiT failed: the model is asked
            log.warning("reasoner unavailable (%s): end-effector kinds are left to the model", e)
            return [Inference(_tool_class(), ()) for _ in tools], time.monotonic() - started
        seconds = time.monotonic() - started
        return [_inference(individual, chains) for individual, chains in individuals], seconds
    finally:
        world.close()


def _inference(individual, chains: dict) -> Inference:
    tax, tool = vocabulary(), _tool_class()
    names = [c.iri[len(CORE_IRI):] for c in individual.is_a
             if isinstance(c, owlready2.ThingClass) and c.iri.startswith(CORE_IRI)]
    under = [n for n in names if n in tax and tax.is_a(n, tool)]
    cls = max(under, key=lambda n: len(tax.ancestors(n)), default=tool)
    thumbs = tuple(name for name, chain in chains.items()
                   if any(getattr(c, "iri", "") == CORE_IRI + THUMB for c in chain.is_a))
    return Inference(cls, thumbs)
