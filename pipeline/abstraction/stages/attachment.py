"""Stage 2, attachment root detection: the link each selected leaf's device is mounted on.

Code offers the candidates, the model picks. Candidates are the leaf's ancestors, nearest first,
up to and including the first one that also carries a leaf identified as another kind of
component: anything higher would make that link a member of the device with a child outside it,
which verification must reject. (The mount of a device abstracted in an earlier pass may lie
inside: a sensor on a gripper's palm.) A sensor is rigidly fixed to its mount, so for sensors the
candidates also end below the first joint that moves: the link above that joint moves relative to
the sensor and cannot be what it is fixed to. (Only a leaf whose own joint moves, which no sensor
frame should, keeps its parent as the one candidate.) Nor is a sensor's own body offered: a fixed link that carries
nothing but the chain down to the leaf, which the file declares a simulator sensor on, or whose name or mesh names a
catalogue product seeing from more than one place, of which that chain is half (one housing of a stereo camera).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Mapping

from urdfkb.pipeline.knowledge.ontology import Kind, vocabulary
from urdfkb.pipeline.abstraction.oracle import Oracle
from urdfkb.pipeline.abstraction.prompts import root_question
from urdfkb.pipeline.abstraction.alike import alike_sets
from urdfkb.pipeline.abstraction.catalogue import catalogue
from urdfkb.pipeline.abstraction.frames import body_of, frames_of_one_body
from urdfkb.pipeline.reading.tree import KinematicTree
from urdfkb.pipeline.abstraction.stages.asking import Progress, ask

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
    lies above a joint that moves, and none is the sensor's own body (_own_body)."""
    candidates: list[str] = []
    chain = tree.chain_to_root(leaf)
    for below, ancestor in zip(chain, chain[1:1 + MAX_CANDIDATES]):
        moved = tree.edge_to(below).joint_type != "fixed"
        if rigid and moved and candidates:
            break  # `below` moves relative to `ancestor`, and so would the sensor fixed to `below`
        if not (rigid and _own_body(tree, ancestor, leaf)):
            candidates.append(ancestor)
        if blocked(ancestor) or any(blocked(d) for d in tree.descendants(ancestor)) or (rigid and moved):
            break
    return candidates or list(chain[1:2])  # a leaf moving on its own joint below its body: that body, as before


def _own_body(tree: KinematicTree, link: str, leaf: str) -> bool:
    """`link` is the body of the sensor `leaf` belongs to, not its mount: it is fixed to a parent, carries nothing
    but a chain of fixed joints down to `leaf`, and either the file declares a simulator sensor on it (the `<gazebo
    reference>` of a camera or lidar is the device) or its own name or mesh names a catalogue product that by the
    ontology sees from more than one place (core:viewpointCount: a stereo camera), of which one chain is half (a
    car's ZED written as two housings, each carrying one camera frame). A body part carries other things."""
    edge = tree.parent_edge(link)
    chain = tree.chain_to_root(leaf)
    if edge is None or edge.movable or not set(tree.descendants(link)) <= set(chain) \
            or any(tree.edge_to(held).movable for held in chain[:chain.index(link)]):
        return False
    facts = tree.evidence.get(link)
    if facts is None:
        return False
    if any(s.reference == link for s in facts.sensors):
        return True
    product = catalogue().match([link, *facts.meshes])
    return product is not None and product.cls in vocabulary().unseen(1, vocabulary().component)


def detect_roots(oracle: Oracle, tree: KinematicTree, leaves: list[str], kind: Kind,
                 blocked: Callable[[str], bool], progress: Progress | None = None, rigid: bool = False,
                 settled: Mapping[str, str] | None = None,
                 settled_blocked: Callable[[str], bool] | None = None) -> list[SubChain]:
    """One sub-chain per leaf; `blocked(link)` says a link cannot lie inside this kind of device;
    `rigid`: devices of this kind are fixed to their mount (sensors); `settled`: leaf → the mount its tree
    shape gives it (a hand's leaves: hands.hand_mounts), taken unasked where it is among the candidates that
    `settled_blocked` (by default `blocked`) leaves.

    Fewer questions than leaves: alike leaves (alike.alike_leaves: a left and a right forearm camera) with
    as many candidates are asked once, each mounted as high up its own chain as the first is on its chain; and
    of the frames of one body (frames.body_of: an RGB-D camera's) the first is asked, the others taking its
    mount where that lies above the body (they would be raised to it anyway: grouping.one_mount) and being
    asked themselves where it does not (a mount on the body itself binds nothing)."""
    candidates = {leaf: mount_candidates(tree, leaf, blocked, rigid) for leaf in leaves}
    chains = {leaf: sub_chain(tree, leaf, c[0]) for leaf, c in candidates.items() if len(c) == 1}
    chains.update({leaf: sub_chain(tree, leaf, mount) for leaf, mount in (settled or {}).items()
                   if leaf in candidates and leaf not in chains
                   and mount in (candidates[leaf] if settled_blocked is None
                                 else mount_candidates(tree, leaf, settled_blocked, rigid))})
    bodies = frames_of_one_body(tree, [leaf for leaf in leaves if leaf not in chains])
    _ask_mounts(oracle, tree, kind, [frames[0] for frames in bodies], candidates, chains, progress)
    rest = []
    for first, *others in bodies:
        mount = chains[first].root
        for leaf in others:
            body = body_of(tree, first, leaf)
            if body is not None and mount in tree.chain_to_root(body)[1:] and mount in candidates[leaf]:
                chains[leaf] = sub_chain(tree, leaf, mount)
            else:
                rest.append(leaf)
    _ask_mounts(oracle, tree, kind, rest, candidates, chains, progress)
    return [chains[leaf] for leaf in leaves]


def _ask_mounts(oracle: Oracle, tree: KinematicTree, kind: Kind, leaves: list[str], candidates: dict[str, list[str]],
                chains: dict[str, SubChain], progress: Progress | None) -> None:
    """The mount of each of `leaves`, into `chains`; alike leaves with as many candidates asked once."""
    sets = alike_sets(tree, leaves, lambda a, b: len(candidates[a]) == len(candidates[b]))
    questions = [root_question(kind, group[0], candidates[group[0]]) for group in sets]
    for group, q, v in zip(sets, questions, ask(oracle, questions, "attachment root detection", progress)):
        depth = q.options.index(v.answer) if v.answer in q.options else 0  # an abstention: on its parent
        for leaf in group:
            chains[leaf] = sub_chain(tree, leaf, candidates[leaf][depth])
