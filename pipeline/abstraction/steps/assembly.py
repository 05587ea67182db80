"""The devices a pass found, as components: each verified group with its class, its links' sub-part
classes and, for a tool, its finger chains."""
from __future__ import annotations

from urdfkb.pipeline.abstraction.components import Component, FingerFact, SubComponent
from urdfkb.pipeline.abstraction.passes import step
from urdfkb.pipeline.abstraction.stages.classification import Typed
from urdfkb.pipeline.abstraction.stages.grouping import Group
from urdfkb.pipeline.abstraction.steps.context import Context
from urdfkb.pipeline.abstraction.steps.devices import mount
from urdfkb.pipeline.abstraction.steps.findings import Findings


def device(ctx: Context, shares: dict[str, float], i: int, g: Group, t: Typed, parts: dict[str, Typed] | None,
           fingers: tuple[FingerFact, ...] = ()) -> Component:
    """The pass's i-th device, group `g` classified `t`; each link typed by `parts` (None: left untyped). Its
    confidence is that of its class times that of its kind: the mean share of the votes by which its leaves were
    identified as this kind (`shares`; 1 where the shape or a declaration decided, as the class is 1 where the
    reasoner did), so a device structure settles on leaves the model hardly took for it still goes to review."""
    kind = ctx.device_kind
    links = [parts[link] if parts is not None else Typed("", 0.0) for link in g.members]
    of_kind = sum(shares.get(leaf, 1.0) for leaf in g.leaves) / len(g.leaves)
    return Component(
        name=f"{kind.name}_{i}_{g.leaves[0]}",
        kind=kind.name,
        cls=t.cls,
        confidence=round(t.confidence * of_kind, 4),
        root=mount(ctx.tree, g),
        subcomponents=tuple(SubComponent(link, p.cls, round(p.confidence, 4)) for link, p in zip(g.members, links)),
        fingers=fingers,
        kind_share=round(of_kind, 4),
    )


@step("assembly", needs=("groups", "post", "parts", "shares"), makes=("found", "components"))
def assembly(ctx: Context, found: Findings) -> None:
    """The pass's devices, added to the components."""
    found.found = [device(ctx, found.shares, i, g, t, found.parts) for i, (g, t) in enumerate(zip(found.groups, found.post))]
    found.components += found.found


@step("assembly", needs=("groups", "post", "parts", "shares", "fingers"), makes=("found", "components"))
def tool_assembly(ctx: Context, found: Findings) -> None:
    """The pass's tools with their finger chains, added to the components."""
    found.found = [device(ctx, found.shares, i, g, t, found.parts, found.fingers[i])
                   for i, (g, t) in enumerate(zip(found.groups, found.post))]
    found.components += found.found
