"""Stand-ins for HermiT with pipeline.knowledge.reasoning.classify_together's and placements' contracts, so pipeline
tests run without a JVM: the ontology's definitions of the end-effector kinds, ThumbChain and the body-part
conditions (ontologies/urdfkb.owl) written out as rules over the facts the code asserts, and the
facts closed as pipeline.knowledge.reasoning closes them; and its ∀isLocatedOn restrictions (PLACEMENTS). Inject them as
`reasoner=scripted_reasoner, placer=scripted_placements` (Abstractor, runner.run), as tests inject a
ScriptedBackend for the model.

test_reasoner_agreement checks it against HermiT on every input the fast lane's robots give it and on
generated robots, so a change to the ontology's definitions that it misses fails there.
"""
from __future__ import annotations

from urdfkb.pipeline.knowledge.ontology import vocabulary
from urdfkb.pipeline.knowledge.reasoning import TOOL_REF, Inference, PartFacts
from urdfkb.pipeline.abstraction.structure import ToolStructure

TOOL = "EndEffector"
HEAD_SPAN = 0.5  # m: a head's cameras lie within this of its first joint (core:deviceSpanMetres in its definition)
PLACEMENTS = {"Bumper": ("MobileBase", "Leg")}  # class → the body parts it may be located on


def scripted_reasoner(tools: list[ToolStructure], parts: list[PartFacts]) -> tuple[list[Inference], list[str | None], float]:
    """Each tool's Inference, each candidate part's class (None where no condition, or two, hold), 0 s."""
    return [_tool(t) for t in tools], _parts(parts), 0.0


def _tool(tool: ToolStructure) -> Inference:
    """ParallelGripper: two chains, one opposing; MultiFingerGripper: three chains, or four or more and no
    thumb; AnthropomorphicHand: four or more and a thumb. A thumb opposes two chains that each move with one."""
    opposes = _symmetric({f.name: f.opposes for f in tool.fingers})
    along = _symmetric({f.name: f.moves_with for f in tool.fingers})
    thumbs = tuple(f.name for f in tool.fingers if sum(bool(along[o]) for o in opposes[f.name]) >= 2)
    n = len(tool.fingers)
    if n == 2 and any(opposes.values()):
        cls = "ParallelGripper"
    elif n == 3 or (n >= 4 and not thumbs):
        cls = "MultiFingerGripper"
    elif n >= 4:
        cls = "AnthropomorphicHand"
    else:
        cls = TOOL
    return Inference(cls, thumbs)


def _symmetric(relation: dict[str, tuple[str, ...]]) -> dict[str, set[str]]:
    """opposes and movesWith are symmetric properties: a pair asserted one way holds both ways."""
    out: dict[str, set[str]] = {name: set(others) for name, others in relation.items()}
    for name, others in relation.items():
        for other in others:
            out[other].add(name)
    return out


def _parts(parts: list[PartFacts]) -> list[str | None]:
    wheels = [_is_wheel(f) for f in parts]
    tooled = [_tools(f) > 0 for f in parts]
    first = [f.known or _part(f, wheels, tooled) for f in parts]
    first = ["MobileBase" if cls is None and _steering_below(f, parts, first) else cls for f, cls in zip(parts, first)]

    def torso(f: PartFacts) -> bool:
        """Off the ground, carrying an arm and a head, or an arm on either side (classes settled or asserted)."""
        carried = {(first[k], parts[k].side) for k in f.carries}
        return not f.reaches_ground and ({"Arm", "Head"} <= {cls for cls, _ in carried}
                                         or {("Arm", "left"), ("Arm", "right")} <= carried)
    return [("Torso" if cls is None and torso(f) else cls) for f, cls in zip(parts, first)]


def _steering_below(f: PartFacts, parts: list[PartFacts], classes: list[str | None]) -> bool:
    """One joint, no end-effector, carrying a joint of the mobile base that carries a wheel (a suspension carrying a
    steering knuckle)."""
    return len(f.joint_types) == 1 and not _tools(f) and any(
        classes[k] == "MobileBase" and any(classes[m] == "Wheel" for m in parts[k].carries) for k in f.carries)


def _is_wheel(f: PartFacts) -> bool:
    """One joint, continuous, not turning about the vertical, carrying no part and no device."""
    tax = vocabulary()
    return (len(f.joint_types) == 1 and tax.is_a(tax.joint_class(f.joint_types[0]), "ContinuousJoint")
            and not f.vertical and not f.carries and not f.devices)


def _tools(f: PartFacts) -> int:
    """How many end-effectors are on the part's links (a tool of the same run is an EndEffector)."""
    tax = vocabulary()
    return sum(d.startswith(TOOL_REF) or tax.is_a(d, TOOL) for d in f.devices)


def _part(f: PartFacts, wheels: list[bool], tooled: list[bool]) -> str | None:
    tax = vocabulary()
    devices = [TOOL if d.startswith(TOOL_REF) else d for d in f.devices]  # a tool of the same run is an EndEffector
    tools = _tools(f)
    joints, ground = len(f.joint_types), f.reaches_ground
    held = {
        "Wheel": _is_wheel(f),
        "Leg": ground and joints >= 2 and not tools,
        "Arm": not ground and (tools > 0 or (joints >= 5 and not f.carries)),
        "Head": (not ground and any(tax.is_a(d, "Camera") for d in devices) and not tools and not f.carries
                 and joints <= 3 and round(f.span, 3) <= HEAD_SPAN and not f.sliding),
        "MobileBase": joints == 1 and any(wheels[k] for k in f.carries) and not tools,
        "Torso": not ground and not tools and sum(tooled[k] for k in f.carries) >= 2,
    }
    settled = [cls for cls, holds in held.items() if holds]
    return settled[0] if len(settled) == 1 else None


def scripted_placements(parts: tuple[str, ...], classes: tuple[str, ...]) -> tuple[dict[str, frozenset[str]], float]:
    """Each body-part class → those of `classes` under a restricted class whose allowed parts it is none of; 0 s."""
    tax = vocabulary()
    return {part: frozenset(c for c in classes for restricted, allowed in PLACEMENTS.items()
                            if tax.is_a(c, restricted) and not any(tax.is_a(part, a) for a in allowed))
            for part in parts}, 0.0
