"""Stage 1, identification: which kind of component (if any) each leaf link belongs to.

Alike leaves (pipeline.structure.alike_leaves: the fingers of a hand, mirrored limbs, a quadruped's feet)
are asked once, the first standing for all, and all get its answer: four
identical fingers can no longer become four different things, and fewer questions are asked. A leaf
that names a catalogue product which is no component (a fiducial marker) is settled without a question."""
from __future__ import annotations

from typing import Callable

from urdfkb.pipeline.catalogue import Product, catalogue
from urdfkb.pipeline.oracle import Oracle
from urdfkb.pipeline.ontology import Vocabulary
from urdfkb.pipeline.prompts import NONE, kind_choice
from urdfkb.pipeline.structure import alike_leaves
from urdfkb.pipeline.tree import KinematicTree
from urdfkb.pipeline.stages.asking import Progress, ask


def named_product(tree: KinematicTree, links: list[str]) -> Product | None:
    """The catalogue product the first of `links` names (its name, then its meshes), or failing that the
    link the last of them is fixed to (a frame of a camera body whose mesh names the camera)."""
    edge = tree.parent_edge(links[-1])
    above = [edge.parent] if edge is not None and not edge.movable else []
    for link in [*links, *above]:
        facts = tree.evidence.get(link)
        if product := catalogue().match([link, *(facts.meshes if facts else ())]):
            return product
    return None


def identify(oracle: Oracle, tax: Vocabulary, tree: KinematicTree, leaves: list[str],
             progress: Progress | None = None, log: Callable[[str], None] | None = None) -> dict[str, tuple[str, float]]:
    """Map each leaf to a direct subclass of Component, or prompts.NONE (also for an abstention), with
    the share of the votes the answer had. A leaf naming a catalogue product that the ontology does not
    place under Component (a fiducial marker) is part of none, unasked: no kind is left to offer."""
    kinds = tax.subclasses(tax.component)
    groups, settled = [], {}
    for group in alike_leaves(tree, leaves):
        product = named_product(tree, [group[0]])
        if product is not None and product.cls in tax and not tax.is_a(product.cls, tax.component):
            if log:
                log(f"{group}: {product.label}, a {tax.label(product.cls)}: part of no component")
            settled.update({leaf: (NONE, 1.0) for leaf in group})
        else:
            groups.append((group, product))
    choices = [
        kind_choice(tax, kinds, group[0], tree.chain_to_root(group[0])[1:], tree.edge_to(group[0]).joint_type, product)
        for group, product in groups
    ]
    verdicts = ask(oracle, [c.question for c in choices], "identification", progress)
    return settled | {leaf: (c.meant(v.answer, NONE), v.confidence)
                      for (group, _), c, v in zip(groups, choices, verdicts) for leaf in group}
