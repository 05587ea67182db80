"""Stage 1, identification: which kind of component (if any) each leaf link belongs to.

Alike leaves (pipeline.abstraction.alike.alike_leaves: the fingers of a hand, mirrored limbs, a quadruped's feet)
are asked once, the first standing for all, and all get its answer: four
identical fingers can no longer become four different things, and fewer questions are asked. A leaf
that names a catalogue product which is no component (a fiducial marker) is settled without a question, and so is
a bare frame fixed where such a piece is (the frame of a face's display screen).
Where the robot's structure rules a kind out for a leaf (no end effector where a limb goes on from the leaf's
body: hands.limb_goes_on), the question stays the same for every leaf, so its system text is shared, and
the answer is the option with the most votes among those left."""
from __future__ import annotations

import math
from collections.abc import Iterable
from typing import Callable

from urdfkb.pipeline.abstraction.catalogue import Product, catalogue
from urdfkb.pipeline.abstraction.frames import MARK_PLACE, is_frame
from urdfkb.pipeline.abstraction.oracle import Oracle, Verdict
from urdfkb.pipeline.knowledge.ontology import Vocabulary, vocabulary
from urdfkb.pipeline.abstraction.prompts import NONE, Choice, kind_choice
from urdfkb.pipeline.abstraction.alike import alike_sets
from urdfkb.pipeline.reading.evidence import SimSensor
from urdfkb.pipeline.reading.tree import KinematicTree
from urdfkb.pipeline.abstraction.stages.asking import Progress, ask
from urdfkb.pipeline.abstraction.stages.attachment import SubChain


def _moves(tree: KinematicTree, link: str) -> bool:
    """A joint that moves hangs from the link."""
    return any(tree.edge_to(child).movable for child in tree.children(link))


def named_product(tree: KinematicTree, links: list[str]) -> Product | None:
    """The catalogue product the first of `links` names (its name, then its meshes, the plugins naming it and the
    names of the simulator sensors declared on it, each where its own type admits what it names: _admitted), or
    failing that the link the last of them is fixed to (a frame
    of a camera body whose mesh names the camera), that link's plugins only for a frame (a plugin naming an arm's
    flange names no body bolted beside it), and never its sensors (a lidar declared on a base names no frame on it).
    The plugins of a link that something moves on name none of the frames fixed to it (a GNSS receiver's plugin on a
    rover's chassis, which its wheels turn on, or on a drone's body, which its rotors spin on)."""
    edge = tree.parent_edge(links[-1])
    above = [edge.parent] if edge is not None and not edge.movable else []
    for link in [*links, *above]:
        facts = tree.evidence.get(link)
        own = link in links
        plugins = facts.plugins if facts and (own or is_frame(tree, links[-1])) and not _moves(tree, link) else ()
        sensors = [s.name for s in facts.sensors if s.name and _admitted(s)] if facts and own else []
        if product := catalogue().match([link, *(facts.meshes if facts else ()), *plugins, *sensors]):
            return product
    return None


def _admitted(sensor: SimSensor) -> bool:
    """The product a simulator sensor's name names, if any, is of a class its declared type admits (the ontology's
    core:simulatorSensorType alignment): a ray scan named for a depth camera (a scan taken from one, or a name
    reused) names no camera. The links' own names and meshes stay evidence against a declared type (a simulator
    stands a type it has in for a product it has none for); a name inside the declaration speaks for that
    declaration."""
    product = catalogue().match([sensor.name])
    vocab = vocabulary()
    if product is None or product.cls not in vocab or (kind := vocab.kind_of(product.cls)) is None:
        return True
    return product.cls not in vocab.disagreeing(vocab.declared_classes([sensor.sdf_type]), vocab.kinds[kind].cls)


def device_product(tree: KinematicTree, chains: Iterable[SubChain]) -> Product | None:
    """The catalogue product a device's links name: the first its sub-chains name, each read from its leaf up."""
    return next((p for c in chains if (p := named_product(tree, list(reversed(c.links)))) is not None), None)


def identify(oracle: Oracle, tax: Vocabulary, tree: KinematicTree, leaves: list[str],
             progress: Progress | None = None, log: Callable[[str], None] | None = None,
             ruled_out: dict[str, frozenset[str]] | None = None) -> dict[str, tuple[str, float]]:
    """Map each leaf to a direct subclass of Component, or prompts.NONE (also for an abstention), with
    the share of the votes the answer had. A leaf naming a catalogue product that the ontology does not
    place under Component (a fiducial marker) is part of none, unasked: no kind is left to offer; one naming
    a component (a suction gripper's tip frame) is of that kind or none, whatever else the votes prefer.
    `ruled_out`: leaf → the kinds its structure rules out (never answered for it)."""
    kinds = tax.subclasses(tax.component)
    ruled = dict(ruled_out or {})
    groups, settled = [], {}
    for group in alike_sets(tree, leaves, lambda a, b: ruled.get(a) == ruled.get(b)):
        if (marked := _marks(tree, tax, group[0])) is not None:
            if log:
                log(f"{group}: where {marked} is, part of no component: its frame")
            settled.update({leaf: (NONE, 1.0) for leaf in group})
            continue
        product = named_product(tree, [group[0]])
        if product is not None and _no_component(tax, product):
            if log:
                log(f"{group}: {product.label}, a {tax.label(product.cls)}: part of no component")
            settled.update({leaf: (NONE, 1.0) for leaf in group})
        else:
            groups.append((group, product))
            if product is not None and product.cls in tax:  # a named product rules kinds out as a declaration does
                out = tax.disagreeing(frozenset({product.cls}), tax.component) & set(kinds)
                ruled.update({leaf: ruled.get(leaf, frozenset()) | out for leaf in group})
    choices = [
        kind_choice(tax, kinds, group[0], tree.chain_to_root(group[0])[1:], tree.edge_to(group[0]).joint_type, product)
        for group, product in groups
    ]
    verdicts = ask(oracle, [c.question for c in choices], "identification", progress)
    answers = dict(settled)
    for (group, _), c, v in zip(groups, choices, verdicts):
        kind, share = _allowed(c, v, ruled.get(group[0], frozenset()))
        if log and kind != c.meant(v.answer, NONE):
            log(f"{group}: {c.meant(v.answer, NONE)} ruled out by structure: {kind} ({share:.2f})")
        answers.update({leaf: (kind, share) for leaf in group})
    return answers


def _marks(tree: KinematicTree, tax: Vocabulary, leaf: str) -> str | None:
    """The piece a bare frame marks: a drawn leaf fixed to the frame's parent, as the frame is, within MARK_PLACE of
    it and naming a catalogue product the ontology places under no component (a display screen, a marker)."""
    edge = tree.parent_edge(leaf)
    if edge is None or edge.movable or not is_frame(tree, leaf):
        return None
    here = tree.position_in(leaf, edge.parent)
    for piece in tree.children(edge.parent):
        if piece == leaf or not tree.is_leaf(piece) or is_frame(tree, piece) or tree.edge_to(piece).movable:
            continue
        if math.dist(here, tree.position_in(piece, edge.parent)) <= MARK_PLACE \
                and (product := named_product(tree, [piece])) is not None and _no_component(tax, product):
            return piece
    return None


def _no_component(tax: Vocabulary, product: Product) -> bool:
    """The product is one the ontology places under no component (a fiducial marker, a display screen)."""
    return product.cls in tax and not tax.is_a(product.cls, tax.component)


def _allowed(choice: Choice, verdict: Verdict, ruled: frozenset[str]) -> tuple[str, float]:
    """The answer the votes give among the options not `ruled` out, with its share."""
    answer = choice.meant(verdict.answer, NONE)
    if answer not in ruled:
        return answer, verdict.confidence
    shares = {choice.meant(option, NONE): share for option, share in verdict.distribution.items()}
    left = {kind: share for kind, share in shares.items() if kind not in ruled}
    best = max(left, key=left.__getitem__, default=NONE)
    return best, left.get(best, 0.0)
