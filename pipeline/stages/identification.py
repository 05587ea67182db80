"""Stage 1, identification: which kind of component (if any) each leaf link belongs to."""
from __future__ import annotations

from ..evidence import describe
from ..oracle import Oracle, Verdict
from ..ontology import Taxonomy
from ..prompts import NONE, Choice, kind_choice
from ..tree import KinematicTree
from .asking import Progress, ask

COMPONENT = "Component"


def identify(oracle: Oracle, tax: Taxonomy, tree: KinematicTree, leaves: list[str],
             progress: Progress | None = None) -> dict[str, str]:
    """Map each leaf to a direct subclass of Component, or prompts.NONE (also for an abstention)."""
    kinds = tax.subclasses(COMPONENT)
    choices = [
        kind_choice(tax, kinds, leaf, tree.chain_to_root(leaf)[1:], tree.parent_edge(leaf).joint_type,
                    describe(tree.evidence, tree.own_chain(leaf)))
        for leaf in leaves
    ]
    verdicts = ask(oracle, [c.question for c in choices], "identification", progress)
    return {leaf: _likeliest_meaning(c, v) for leaf, c, v in zip(leaves, choices, verdicts)}


def _likeliest_meaning(choice: Choice, verdict: Verdict) -> str:
    """The meaning with the largest summed share (several answers may mean NONE); NONE on abstention."""
    if verdict.answer is None:
        return NONE
    shares: dict[str, float] = {}
    for answer, share in verdict.distribution.items():
        meaning = choice.meaning[answer]
        shares[meaning] = shares.get(meaning, 0.0) + share
    return max(shares, key=shares.__getitem__)
