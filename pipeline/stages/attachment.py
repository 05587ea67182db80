"""Stage 2, attachment root detection: the link each selected leaf's device is mounted on."""
from __future__ import annotations

from dataclasses import dataclass

from ..oracle import Oracle
from ..prompts import root_question
from ..tree import KinematicTree
from .asking import Progress, ask

MAX_ANCESTORS = 8  # candidate mounts offered, nearest first


@dataclass(frozen=True)
class SubChain:
    """A selected leaf with its mount: `links` runs from just below the root down to the leaf."""

    leaf: str
    root: str
    links: tuple[str, ...]
    root_confidence: float


def sub_chain(tree: KinematicTree, leaf: str, root: str, confidence: float) -> SubChain:
    """The trimmed chain root (exclusive) → leaf."""
    chain = tree.chain_to_root(leaf)
    return SubChain(leaf, root, tuple(reversed(chain[:chain.index(root)])), confidence)


def detect_roots(oracle: Oracle, tree: KinematicTree, leaves: list[str], kind_label: str,
                 progress: Progress | None = None) -> list[SubChain]:
    """One sub-chain per leaf, its root chosen by the model among the leaf's ancestors."""
    asked, chains = [], {}
    for leaf in leaves:
        ancestors = tree.chain_to_root(leaf)[1:1 + MAX_ANCESTORS]
        if len(ancestors) == 1:
            chains[leaf] = sub_chain(tree, leaf, ancestors[0], 1.0)
        else:
            asked.append((leaf, root_question(kind_label, leaf, ancestors)))
    verdicts = ask(oracle, [q for _, q in asked], "attachment root detection", progress)
    for (leaf, q), v in zip(asked, verdicts):
        root = v.answer or q.options[0]  # an abstention mounts the device on its parent
        chains[leaf] = sub_chain(tree, leaf, root, v.confidence)
    return [chains[leaf] for leaf in leaves]
