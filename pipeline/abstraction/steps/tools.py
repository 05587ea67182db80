"""The end-effectors' steps: each tool's extent and mount by structure, its kind by the reasoner from the
ontology's definitions, the model asked only where the structure settles none (stages.tools,
pipeline.knowledge.reasoning)."""
from __future__ import annotations

from dataclasses import replace

from urdfkb.pipeline.knowledge import reasoning
from urdfkb.pipeline.abstraction.alike import alike_sets
from urdfkb.pipeline.abstraction.components import FingerFact
from urdfkb.pipeline.abstraction.hands import frozen_jaws
from urdfkb.pipeline.reading.evidence import named as named_link
from urdfkb.pipeline.abstraction.passes import step
from urdfkb.pipeline.abstraction.prompts import RIGID_TOOL
from urdfkb.pipeline.abstraction.stages import body as body_stage
from urdfkb.pipeline.abstraction.stages import tools
from urdfkb.pipeline.abstraction.stages.classification import Subject, Typed, descend
from urdfkb.pipeline.abstraction.stages.grouping import Group
from urdfkb.pipeline.abstraction.stages.identification import device_product
from urdfkb.pipeline.abstraction.steps.assembly import device
from urdfkb.pipeline.abstraction.steps.context import Context
from urdfkb.pipeline.abstraction.steps.devices import mount
from urdfkb.pipeline.abstraction.steps.findings import Findings
from urdfkb.pipeline.abstraction.structure import nothing_moves


@step("tool extent", needs=("groups", "claims"), makes=("groups", "structures"))
def tool_extent(ctx: Context, found: Findings) -> None:
    """Each tool's links and mount, and its structure (stages.tools.settle)."""
    cls, claims = ctx.device_kind.cls, found.claims
    settled = tools.settle(ctx.tree, found.groups, lambda leaf: claims.get(leaf) == cls, ctx.log)
    found.groups = [g for g, _ in settled]
    found.structures = [structure for _, structure in settled]


@step("reasoner", needs=("groups", "structures", "components", "shares"), makes=("inferred", "fingers", "body_reasoned"))
def reasoner(ctx: Context, found: Findings) -> None:
    """Each tool's class from the ontology's definitions over its structure, and its finger chains.

    The body pass's candidates are known here already (the tools' links and mounts are settled; only
    their classes are not), so where a tool has finger chains (the reasoner runs anyway) the one run also
    classifies those, each tool standing as its own individual among the devices; the body pass takes
    those classes where its facts come out the same (every tool on a candidate settled by this run), else
    runs the reasoner itself: a JVM with HermiT costs seconds."""
    structures = found.structures
    parts = _body_facts(ctx, found) if any(t.fingers for t in structures) else []
    if parts:
        found.inferred, classes, seconds = ctx.reasoner(structures, parts)
        found.body_reasoned = ([replace(f, devices=tuple(_settled(d, found.inferred) for d in f.devices))
                                for f in parts], classes)
    else:
        found.inferred, seconds = reasoning.classify(structures, ctx.reasoner)
    ctx.tally.reasoner_seconds += seconds
    ctx.trace({"key": "reasoner", "seconds": round(seconds, 2), "tools": [
        {"leaves": g.leaves, "facts": st.describe(), "inferred": i.cls, "thumbs": list(i.thumbs)}
        for g, st, i in zip(found.groups, structures, found.inferred)]})
    found.fingers = [tuple(FingerFact(f.name, f.drive, ctx.vocab.finger_chain_class(f.motion), f.name in i.thumbs,
                                      f.opposes, f.moves_with, f.mimics) for f in st.fingers)
                     for st, i in zip(structures, found.inferred)]


def _body_facts(ctx: Context, found: Findings) -> list[reasoning.PartFacts]:
    """The body pass's candidates' facts, with this pass's tools as assembly will make them but for
    their classes and finger chains: tool i's class is reasoning.TOOL_REF + i."""
    made = [device(ctx, found.shares, i, g, Typed(f"{reasoning.TOOL_REF}{i}", 0.0), None)
            for i, g in enumerate(found.groups)]
    components = body_stage.with_joints(ctx.robot, found.components + made)
    candidates = body_stage.candidates(ctx.robot, components)
    return body_stage.findings(ctx.robot, candidates, components).facts if candidates else []


def _settled(device: str, inferred: list[reasoning.Inference]) -> str:
    """A device as the body pass will see it: a tool the run settled by its inferred class; a tool left
    open by a name no class has (the model decides it later, so those facts never match)."""
    if not device.startswith(reasoning.TOOL_REF):
        return device
    inference = inferred[int(device[len(reasoning.TOOL_REF):])]
    return inference.cls if inference.settled else f"{device} (open)"


@step("end-effector classification", needs=("groups", "structures", "inferred", "frozen_tips"), makes=("post",))
def tool_classification(ctx: Context, found: Findings) -> None:
    """The model is asked the kind of the tools whose structure settles none, seeing what each is mounted
    on (a fingerless tool on a link whose mesh is a hand is a hand). A tool in which nothing moves
    (structure.nothing_moves) may also stay a plain end effector (prompts.RIGID_TOOL: a probe, a ball), which the
    ontology allows and no kind below it fits, unless its links name a catalogue product of a kind below
    (a suction gripper's tip frame): then the kinds that product is not are not offered. A tool holding the tips of
    fingers written fixed (hands.frozen_fingertips) is described so (as jaws where they are a gripper's,
    hands.frozen_jaws), and is no rigid tool. Alike tools (alike.alike_sets: a left and a right hand) told the same
    structure and offered the same answers are asked once, the first standing for all, as alike sensors are."""
    tree, top = ctx.tree, ctx.device_kind.cls
    open_groups = [(g, st) for g, st, i in zip(found.groups, found.structures, found.inferred) if not i.settled]
    ruled = [_product_rules_out(ctx, g, top) for g, _ in open_groups]
    tips = found.frozen_tips
    frozen = [[leaf for leaf in g.leaves if leaf in tips] for g, _ in open_groups]
    jaws = frozen_jaws(tree) if any(frozen) else frozenset()
    # by each tool's first leaf: what its question tells and offers
    told: dict[str, tuple[str, frozenset[str], tuple[str, str] | None]] = {}
    subjects: dict[str, Subject] = {}
    for (g, st), out, fixed in zip(open_groups, ruled, frozen):
        phrase = _written_fixed(fixed, jaws) if fixed else st.describe()
        stay = RIGID_TOOL if nothing_moves(tree, st, mount(tree, g)) and not out and not fixed else None
        told[g.leaves[0]] = (phrase, out, stay)
        subjects[g.leaves[0]] = Subject(f"post:{g.leaves[0]}", "The links below form one {concept}.",
                                        f"Links: {', '.join(g.leaves)}\nOn: {named_link(tree.evidence, mount(tree, g))}"
                                        f"\nStructure: {phrase}", out, stay=stay)
    sets = alike_sets(tree, list(subjects), lambda a, b: told[a] == told[b])
    asked = descend(ctx.oracle, ctx.vocab, top, [subjects[leaves[0]] for leaves in sets],
                    "end-effector classification", ctx.progress)
    by_leaf = {leaf: t for leaves, t in zip(sets, asked) for leaf in leaves}
    found.post = [by_leaf[g.leaves[0]] if not i.settled else Typed(i.cls, 1.0)
                  for g, i in zip(found.groups, found.inferred)]


def _written_fixed(tips: list[str], jaws: frozenset[str]) -> str:
    """A tool's fingers written fixed, as the model is told: a gripper's jaws (hands.frozen_jaws), or fingers."""
    if set(tips) <= jaws:
        return "jaws written fixed, facing each other in mirror-image pairs"
    return f"{len(tips)} fingers written fixed"


def _product_rules_out(ctx: Context, g: Group, top: str) -> frozenset[str]:
    """The classes under `top` a catalogue product the tool's links name rules out, as a declaration would
    (Vocabulary.disagreeing); none where no product of a kind under `top` is named."""
    product = device_product(ctx.tree, g.chains)
    if product is None or product.cls not in ctx.vocab:
        return frozenset()
    return ctx.vocab.disagreeing(frozenset({product.cls}), top)
