"""Which links make each device: each selected leaf's mount (attachment), leaves grouped into devices
(group merging) and groups checked to own their subtrees (verification): stages.attachment, .grouping,
.verification."""
from __future__ import annotations

from typing import Callable

from urdfkb.pipeline.abstraction.components import END_EFFECTOR
from urdfkb.pipeline.abstraction.passes import step
from urdfkb.pipeline.abstraction.prompts import NONE
from urdfkb.pipeline.abstraction.stages.attachment import detect_roots
from urdfkb.pipeline.abstraction.stages.grouping import INERTIAL, VISION, Group, merge, one_mount
from urdfkb.pipeline.abstraction.stages.verification import group_root, verify
from urdfkb.pipeline.abstraction.steps.context import Context
from urdfkb.pipeline.abstraction.steps.findings import Findings
from urdfkb.pipeline.reading.tree import KinematicTree


@step("attachment", needs=("leaves", "claims", "hand_mounts"), makes=("chains", "done"))
def attachment(ctx: Context, found: Findings) -> None:
    """Each leaf identified as the pass's kind with its mount: a hand's leaves where its shape says, the
    others asked; the pass is done when no leaf is of its kind."""
    _attach(ctx, found, found.hand_mounts, rigid=False)


@step("attachment", needs=("leaves", "claims"), makes=("chains", "done"))
def rigid_attachment(ctx: Context, found: Findings) -> None:
    """Attachment for devices fixed to their mount (sensors): frames of one body share one mount
    (grouping.one_mount)."""
    _attach(ctx, found, {}, rigid=True)
    if not found.done:
        found.chains = one_mount(ctx.tree, found.chains)


def _attach(ctx: Context, found: Findings, settled: dict[str, str], rigid: bool) -> None:
    kind = ctx.device_kind
    selected = [leaf for leaf in found.leaves if found.claims[leaf] == kind.cls]
    if not selected:
        found.done = True
        return
    found.chains = detect_roots(ctx.oracle, ctx.tree, selected, kind, _blocked(ctx.tree, found.claims, kind.cls),
                                ctx.progress, rigid=rigid, settled=settled,
                                settled_blocked=_blocked(ctx.tree, found.claims, kind.cls, ctx.vocab.body_part))


def _blocked(tree: KinematicTree, claims: dict[str, str], cls: str, passing: str = NONE) -> Callable[[str], bool]:
    """A link a device of class `cls` cannot contain: a leaf identified as another kind of component, but
    `passing` (for a hand its shape settles, a body part: a cover fixed on the palm its fingers fork from is the
    hand's). (The mount of a device abstracted earlier may lie inside: a sensor on a gripper's palm.)"""
    def blocked(link: str) -> bool:
        return tree.is_leaf(link) and claims.get(link, NONE) not in (cls, NONE, passing)
    return blocked


@step("group merging", needs=("chains", "pre"), makes=("groups",))
def group_merging(ctx: Context, found: Findings) -> None:
    """Sub-chains into devices, sub-chains of one sensor category together (stages.grouping.merge)."""
    kind = ctx.device_kind
    categories = {leaf: category(ctx, t.cls, kind.cls) for leaf, t in found.pre.items()}
    found.groups = merge(ctx.oracle, ctx.tree, found.chains, kind.name, categories, ctx.progress,
                         _measuring_apart(ctx, [c.leaf for c in found.chains]))


def _measuring_apart(ctx: Context, leaves: list[str]) -> frozenset[str]:
    """Leaves the file declares, on themselves, a simulator sensor of a kind no camera carries: of a category other
    than vision and inertial (a sonar's frame beside a downward camera). A camera's own inertial frames belong to it;
    such a frame measures apart from any camera beside it."""
    carried = {c for c in ctx.vocab.subclasses(ctx.device_kind.cls) if c in (VISION, INERTIAL)}
    apart = []
    for leaf in leaves:
        facts = ctx.tree.evidence.get(leaf)
        own = [s.sdf_type for s in facts.sensors if s.reference == leaf] if facts is not None else []
        declared = ctx.vocab.declared_classes(own)
        if declared and not any(ctx.vocab.is_a(c, k) for c in declared for k in carried):
            apart.append(leaf)
    return frozenset(apart)


@step("group merging", needs=("chains",), makes=("groups",))
def tool_merging(ctx: Context, found: Findings) -> None:
    """Sub-chains into tools: those that meet inside one (stages.grouping.merge, no categories)."""
    found.groups = merge(ctx.oracle, ctx.tree, found.chains, ctx.device_kind.name, {}, ctx.progress)


def category(ctx: Context, cls: str, top: str) -> str:
    """The class directly under `top` that `cls` falls in (itself if it is `top`)."""
    return next((c for c in ctx.vocab.subclasses(top) if ctx.vocab.is_a(cls, c)), cls)


@step("verification", needs=("groups", "claims", "components"), makes=("groups",))
def verification(ctx: Context, found: Findings) -> None:
    """Groups that own every link below them (stages.verification.verify)."""
    passing = ctx.vocab.body_part if ctx.device_kind.name == END_EFFECTOR else NONE
    found.groups = verify(ctx.tree, found.groups, _unclaimed(ctx.tree, found.claims, found.groups,
                                                             {c.root for c in found.components}, passing), ctx.log)


def _unclaimed(tree: KinematicTree, claims: dict[str, str], groups: list[Group],
               mounts: set[str], passing: str = NONE) -> Callable[[str], bool]:
    """A link no component holds: not grouped, no device's mount, and no leaf but one identified as none (or as
    `passing`: for a tool, a body part, as attachment lets it lie inside: _blocked)."""
    grouped = {m for g in groups for m in g.members}

    def unclaimed(link: str) -> bool:
        if link in mounts or link in grouped:
            return False
        return not tree.is_leaf(link) or claims.get(link) in (NONE, passing)
    return unclaimed


def mount(tree: KinematicTree, group: Group) -> str:
    """The one link carrying a verified group (verification splits a group with several)."""
    root = group_root(tree, group)
    if root is None:
        raise ValueError(f"the group of {group.leaves} has several mounts after verification")
    return root
