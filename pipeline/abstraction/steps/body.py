"""The body pass's steps: the movable joints no device owns grouped into body parts, classified, sided,
each component located on one, and the ontology's placement restrictions checked (stages.body)."""
from __future__ import annotations

from dataclasses import replace

from urdfkb.pipeline.abstraction.components import Component
from urdfkb.pipeline.abstraction.prompts import NONE
from urdfkb.pipeline.reading.evidence import named
from urdfkb.pipeline.abstraction.passes import step
from urdfkb.pipeline.abstraction.stages import body as body_stage
from urdfkb.pipeline.abstraction.stages.attachment import sub_chain
from urdfkb.pipeline.abstraction.stages.classification import Subject, descend
from urdfkb.pipeline.abstraction.steps.classify import chain_subject
from urdfkb.pipeline.abstraction.steps.context import Context
from urdfkb.pipeline.abstraction.steps.findings import Findings
from urdfkb.pipeline.knowledge.screen import unsure


@step("device joints", needs=("components",), makes=("components",))
def device_joints(ctx: Context, found: Findings) -> None:
    """Each component with the joints inside it."""
    found.components = body_stage.with_joints(ctx.robot, found.components)


@step("candidates", needs=("components",), makes=("candidates", "done"))
def candidates(ctx: Context, found: Findings) -> None:
    """The chains of movable joints no device owns; the pass is done when there are none and no main body
    without joints may be a mobile base (stages.body.main_body). A sensor that will be held back for review
    (pipeline.knowledge.screen.unsure) owns nothing here, nor is it carried (_written): what is not written decides no
    body part (a small humanoid's forearm the model took for a camera, under the floor, made its arm a head)."""
    written = _written(ctx, found.components)
    found.candidates = body_stage.candidates(ctx.robot, written)
    found.done = not found.candidates and body_stage.main_body(ctx.robot, written) is None


def _written(ctx: Context, components: list[Component]) -> list[Component]:
    return [c for c in components if not unsure(ctx.robot, c)]


@step("body classification", needs=("candidates", "components", "body_reasoned"), makes=("candidates",))
def body_classification(ctx: Context, found: Findings) -> None:
    """Each candidate's class: the reasoner's (that of the end-effector pass's run where its facts are the
    same), the model's where no definition holds."""
    def reasoned(seconds: float) -> None:
        ctx.tally.reasoner_seconds += seconds
    body_stage.classify(ctx.oracle, ctx.vocab, ctx.robot, found.candidates, _written(ctx, found.components),
                        ctx.progress, ctx.log, reasoned, found.body_reasoned, ctx.reasoner)


@step("assembly", needs=("candidates",), makes=("body", "candidates"))
def body_assembly(ctx: Context, found: Findings) -> None:
    """The classified candidates as body parts (stages.body.assemble joins a chain's lone follower of its class
    into it, among the candidates themselves)."""
    found.body = body_stage.assemble(ctx.vocab, ctx.robot, found.candidates)


@step("jointless base", needs=("body", "components", "candidates"), makes=("body",))
def jointless_base(ctx: Context, found: Findings) -> None:
    """Where no part moves the robot about, whether its main body is a mobile base with no joints of its own (the
    joints of candidates classified as no body part move none)."""
    idle = frozenset(e.joint for c in found.candidates if c.cls == NONE for e in c.joints)
    found.body = body_stage.jointless_base(ctx.oracle, ctx.vocab, ctx.robot, found.body,
                                           _written(ctx, found.components), ctx.progress, ctx.log, idle)


@step("sides", needs=("body",), makes=("body",))
def sides(ctx: Context, found: Findings) -> None:
    """Each body part's side."""
    found.body = body_stage.sides(ctx.oracle, ctx.robot, found.body, ctx.progress, ctx.log)


@step("location", needs=("body", "components"), makes=("components",))
def location(ctx: Context, found: Findings) -> None:
    """Each component located on the body part it is mounted on."""
    found.components = [body_stage.locate(ctx.robot, c, found.body) for c in found.components]


@step("placement", needs=("body", "components"), makes=("components",))
def placement(ctx: Context, found: Findings) -> None:
    """The property-restriction loop: a component whose class says where it may sit (Vocabulary.placement:
    a bumper on a mobile base or a leg) is checked by the reasoner against the body part it is located on;
    where its class is inconsistent with that part, it is asked its class question again from its kind
    down, without the classes the part rules out, and the trace records the restriction that fired.
    The question is its sub-chain's pre-classification (a device of several frames: its frames together),
    so only the options change. Its sub-parts stay as typed: a new class that requires other parts is
    held back for review by the shapes (pipeline.knowledge.screen). Its confidence is the new class's share times
    its kind's, as assembly.device gives it."""
    vocab = ctx.vocab
    sits = {p.name: p.cls for p in found.body}
    checked = [(c, sits[c.located_on]) for c in found.components if c.located_on is not None and vocab.placement(c.cls)]
    if not checked:
        return
    placed = tuple(c for kind in vocab.kinds.values() for c in vocab.subclasses_below(kind.cls) if vocab.placement(c))
    ruled, seconds = ctx.placer(vocab.body_classes, placed)
    ctx.tally.reasoner_seconds += seconds
    for comp, part in [(c, part) for c, part in checked if c.cls in ruled[part]]:
        (typed,) = descend(ctx.oracle, vocab, vocab.kinds[comp.kind].cls,
                           [_class_question(ctx, comp, ruled[part])], "placement", ctx.progress)
        restriction = vocab.placement(comp.cls)
        ctx.log(f"placement: {comp.name} is no {comp.cls} on a {part} ({restriction}): asked again, {typed.cls}")
        ctx.trace({"key": "placement", "component": comp.name, "class": comp.cls, "located_on": comp.located_on,
                   "part_class": part, "restriction": restriction, "reasked": typed.cls,
                   "confidence": round(typed.confidence, 4)})
        confidence = round(typed.confidence * comp.kind_share, 4)
        found.components = [replace(c, cls=typed.cls, confidence=confidence) if c is comp else c
                            for c in found.components]


def _class_question(ctx: Context, comp: Component, excluded: frozenset[str]) -> Subject:
    """A device's class question without `excluded`: its one leaf's pre-classification, or its frames together."""
    tree = ctx.robot
    leaves = [link for link in comp.links if tree.is_leaf(link)] or list(comp.links)
    if len(leaves) == 1:
        asked = chain_subject(ctx, tree, sub_chain(tree, leaves[0], comp.root), ctx.vocab.kinds[comp.kind].cls)
        return replace(asked, key=f"placement:{leaves[0]}", exclude=asked.exclude | excluded)
    return Subject(f"placement:{leaves[0]}", "The frames below form one {concept} device.",
                   "Frames: " + "; ".join(named(tree.evidence, leaf) for leaf in leaves), excluded)
