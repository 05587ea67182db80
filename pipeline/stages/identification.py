"""Stage 1, identification: which kind of component (if any) each leaf link belongs to."""
from __future__ import annotations

from urdfkb.pipeline.oracle import Oracle
from urdfkb.pipeline.ontology import Vocabulary
from urdfkb.pipeline.prompts import NONE, kind_choice
from urdfkb.pipeline.tree import KinematicTree
from urdfkb.pipeline.stages.asking import Progress, ask

def identify(oracle: Oracle, tax: Vocabulary, tree: KinematicTree, leaves: list[str],
             progress: Progress | None = None) -> dict[str, tuple[str, float]]:
    """Map each leaf to a direct subclass of Component, or prompts.NONE (also for an abstention), with
    the share of the votes the answer had."""
    kinds = tax.subclasses(tax.component)
    choices = [
        kind_choice(tax, kinds, leaf, tree.chain_to_root(leaf)[1:], tree.edge_to(leaf).joint_type)
        for leaf in leaves
    ]
    verdicts = ask(oracle, [c.question for c in choices], "identification", progress)
    return {leaf: (c.meant(v.answer, NONE), v.confidence) for leaf, c, v in zip(leaves, choices, verdicts)}
