"""Stage 2, attachment root detection: the link each selected leaf's device is mounted on.

Code offers the candidates, the model picks. Candidates are the leaf's ancestors, nearest first,
up to and including the first one that also carries a leaf identified as another kind of
component: anything higher would make that link a member of the device with a child outside it,
which verification must reject. (The mount of a device abstracted in an earlier pass may lie
inside: a sensor on a gripper's palm.) A sensor is rigidly fixed to its mount, so for sensors the
candidates also end below the first joint that moves: the link above that joint moves relative to
the sensor and cannot be what it is fixed to. (Only a leaf whose own joint moves, which no sensor
frame should, keeps its parent as the one candidate.)
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

from urdfkb.pipeline.ontology import Kind
from urdfkb.pipeline.oracle import Oracle
from urdfkb.pipeline.prompts import root_question
from urdfkb.pipeline.tree import KinematicTree
from urdfkb.pipeline.stages.asking import Progress, ask

MAX_CANDIDATES = 8


@dataclass(frozen=True)
class SubChain:
    """A selected leaf with its mount: `links` runs from just below the root down to the leaf."""

    leaf: str
    root: str
    links: tuple[str, ...]


def sub_chain(tree: KinematicTree, leaf: str, root: str) -> SubChain:
    """The trimmed chain root (exclusive) → leaf."""
    chain = tree.chain_to_root(leaf)
    return SubChain(leaf, root, tuple(reversed(chain[:chain.index(root)])))


def mount_candidates(tree: KinematicTree, leaf: str, blocked: Callable[[str], bool], rigid: bool = False) -> list[str]:
    """Ancestors that could be the mount, nearest first; `rigid`: the device is fixed to its mount, so none
    lies above a joint that moves."""
    candidates: list[str] = []
    chain = tree.chain_to_root(leaf)
    for below, ancestor in zip(chain, chain[1:1 + MAX_CANDIDATES]):
        moved = tree.edge_to(below).joint_type != "fixed"
        if rigid and moved and candidates:
            break  # `below` moves relative to `ancestor`, and so would the sensor fixed to `below`
        candidates.append(ancestor)
        if blocked(ancestor) or any(blocked(d) for d in tree.descendants(ancestor)) or (rigid and moved):
            break
    return candidates


def detect_roots(oracle: Oracle, tree: KinematicTree, leaves: list[str], kind: Kind,
                 blocked: Callable[[str], bool], progress: Progress | None = None, rigid: bool = False) -> list[SubChain]:
    """One sub-chain per leaf; `blocked(link)` says a link cannot lie inside this kind of device;
    `rigid`: devices of this kind are fixed to their mount (sensors)."""
    asked, chains = [], {}
    for leaf in leaves:
        candidates = mount_candidates(tree, leaf, blocked, rigid)
        if len(candidates) == 1:
            chains[leaf] = sub_chain(tree, leaf, candidates[0])
        else:
            asked.append((leaf, root_question(kind, leaf, candidates)))
    verdicts = ask(oracle, [q for _, q in asked], "attachment root detection", progress)
    for (leaf, q), v in zip(asked, verdicts):
        root = v.answer or q.options[0]  # an abstention mounts the device on its parent
        chains[leaf] = sub_chain(tree, leaf, root)
    return [chains[leaf] for leaf in leaves]
