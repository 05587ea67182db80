"""Each leaf's kind: identification (what shape settles, the model for the rest), then the sensor pass's
checks that take leaves back from the sensors (pipeline.abstraction.stages.identification, stages.sensor_check)."""
from __future__ import annotations

from urdfkb.pipeline.abstraction.components import END_EFFECTOR, SENSOR
from urdfkb.pipeline.abstraction.passes import step
from urdfkb.pipeline.abstraction.prompts import NONE
from urdfkb.pipeline.abstraction.stages.identification import identify, named_product
from urdfkb.pipeline.abstraction.stages.sensor_check import coupled, not_sensors
from urdfkb.pipeline.abstraction.steps.context import Context
from urdfkb.pipeline.abstraction.steps.findings import Findings
from urdfkb.pipeline.abstraction.frames import body_of, frames_of_one_body


@step("identification", needs=("components", "hand_mounts", "feet", "body_feet", "off_ends", "limb_ends",
                               "swinging", "jaws", "rolling_ends", "last_segments", "frozen_tips", "rods", "struts", "loop_frames",
                               "collision_volumes", "palms", "declared_sensors"),
      makes=("leaves", "claims", "shares"))
def identification(ctx: Context, found: Findings) -> None:
    """The pass's leaves (not where an earlier pass condensed a device, but a hand's fingertip whose sensors it
    condensed) and each one's kind: from shape and the file's declarations where they settle it, else asked
    (stages.identification)."""
    vocab, claims, shares = ctx.vocab, found.claims, found.shares
    mounts = {c.root for c in found.components}  # where earlier passes condensed their devices
    found.leaves = [leaf for leaf in ctx.tree.leaves() if leaf not in mounts or leaf in found.hand_mounts]
    tools = vocab.kinds[END_EFFECTOR].cls if END_EFFECTOR in vocab.kinds else None
    sensors = vocab.kinds[SENSOR].cls if SENSOR in vocab.kinds else None
    body = vocab.body_part  # what identification calls a leaf of the body
    body = body if body in vocab.subclasses(vocab.component) else NONE
    for leaf in found.leaves:
        if leaf in found.loop_frames and leaf not in claims:
            ctx.log(f"{leaf}: where a closed kinematic loop is cut (it coincides with a frame across a moving joint)")
            claims[leaf], shares[leaf] = NONE, 1.0
        elif leaf in found.collision_volumes and leaf not in claims:
            ctx.log(f"{leaf}: drawn at its parent's origin for collision checking alone: more of that body")
            claims[leaf], shares[leaf] = NONE, 1.0
        elif tools and leaf in found.hand_mounts and leaf not in claims:
            claims[leaf], shares[leaf] = tools, 1.0
        elif leaf in found.declared_sensors and leaf not in claims and sensors:
            ctx.log(f"{leaf}: the file declares a simulator sensor on it: a sensor")
            claims[leaf], shares[leaf] = sensors, 1.0
        elif leaf in found.body_feet and leaf not in claims:
            ctx.log(f"{leaf}: a foot the robot stands on, the leg's last link or a body of its own: part of the body")
            claims[leaf], shares[leaf] = body, 1.0
    unasked = [leaf for leaf in found.leaves if leaf not in claims]
    # the kinds a leaf's place rules out; a leaf naming a tool product (a suction cup on the servo that turns it) is
    # a tool wherever it ends
    no_tool = found.off_ends | found.rolling_ends | found.last_segments
    named_tools = {leaf for leaf in no_tool.intersection(unasked) if tools and (product := named_product(ctx.tree, [leaf]))
                   and product.cls in vocab and vocab.is_a(product.cls, tools)}
    rules = ((tools, no_tool - named_tools),
             (sensors, found.limb_ends | found.swinging | found.jaws | found.frozen_tips | found.rods | found.struts))
    ruled = {leaf: out for leaf in unasked if (out := frozenset(k for k, where in rules if k and leaf in where))}
    for leaf, (kind, share) in identify(ctx.oracle, vocab, ctx.tree, unasked, ctx.progress, ctx.log, ruled).items():
        if kind == tools and leaf in found.feet:  # the tip of a leg: part of the body, as the body pass will find
            ctx.log(f"{leaf}: a foot the robot stands on, not a tool")
            kind = body
        claims[leaf], shares[leaf] = kind, share
    _one_kind_per_body(ctx, found)


def _one_kind_per_body(ctx: Context, found: Findings) -> None:
    """Frames of one body are one device (grouping binds them), so they are of one kind: where the model
    split them between the device passes' kinds, the kind with the larger sum of vote shares over them
    takes them all (a hand's leaf, known from structure, counts one), unless products they or their body name are
    of one kind only and no frame of another kind is settled by a declaration or the shape: then the products'
    kind takes them (a vacuum gripper's cup beside the arm's unnamed tool frame; a depth camera's frames on a
    housing drawn with the camera's mesh). Not on a hand's palm, which carries its tool frames beside its sensors'
    frames (an IMU), unless the body they hang from names a product: a camera housing bolted to the hand."""
    vocab = ctx.vocab
    devices = {vocab.kinds[k].cls for k in (SENSOR, END_EFFECTOR) if k in vocab.kinds}
    claims, palms = found.claims, found.palms
    settled = found.declared_sensors | set(found.hand_mounts)
    claimed = [leaf for leaf in found.leaves if claims.get(leaf) in devices]

    def kinds_named(links: list[str]) -> set[str]:
        return {kind for link in links if (product := named_product(ctx.tree, [link])) and product.cls in vocab
                for kind in devices if vocab.is_a(product.cls, kind)}
    for frames in frames_of_one_body(ctx.tree, claimed):
        totals: dict[str, float] = {}
        for leaf in frames:
            totals[claims[leaf]] = totals.get(claims[leaf], 0.0) + found.shares[leaf]
        if len(totals) < 2:
            continue
        body = body_of(ctx.tree, frames[0], frames[1])
        housing = kinds_named([body]) if body is not None else set()
        if body in palms and not housing:
            continue  # a hand's palm carries its tool frames beside its sensors' (an IMU)
        named = kinds_named(frames) | housing
        if len(named) == 1 and not any(claims[leaf] not in named for leaf in frames if leaf in settled):
            kind, why = next(iter(named)), "the kind of the product they name"
        else:
            kind = max(totals, key=totals.__getitem__)
            why = ", ".join(f"{k} {v:.2f}" for k, v in totals.items())
        ctx.log(f"frames of one body {frames}: all {kind} ({why})")
        for leaf in frames:
            claims[leaf] = kind


def claimed(ctx: Context, found: Findings) -> set[str]:
    """The pass's leaves identified as its kind."""
    return {leaf for leaf in found.leaves if found.claims[leaf] == ctx.device_kind.cls}


@step("mimic veto", needs=("leaves", "claims"), makes=("claims",))
def mimic_veto(ctx: Context, found: Findings) -> None:
    """A leaf moving on a mimic joint follows another, one on a joint others follow drives them: no sensor
    (stages.sensor_check.coupled)."""
    for leaf in coupled(ctx.tree, found.leaves, claimed(ctx, found), ctx.log):
        found.claims[leaf] = NONE


@step("sensor check", needs=("leaves", "claims", "shares"), makes=("claims",))
def sensor_check(ctx: Context, found: Findings) -> None:
    """Leaves the model took for sensors on a thin majority, asked again whether they measure
    (stages.sensor_check.not_sensors)."""
    sensors = {leaf: found.shares[leaf] for leaf in claimed(ctx, found)}
    for leaf in not_sensors(ctx.oracle, ctx.vocab, ctx.tree, found.leaves, sensors, ctx.log, ctx.progress):
        found.claims[leaf] = NONE
