"""The findings record: what the steps of the abstraction find about one robot.

A fresh record is made for every robot, and every pass starts from a fresh one (`next_pass`) that keeps
only the fields marked as lasting: the components found so far, what the robot's shape settles, the
identification claims, the reasoner's classes of the body candidates and the body parts. Every other
field is the current pass's own. Steps declare the fields they read and make (pipeline.abstraction.passes.step),
and those names are checked against the fields here.
"""
from __future__ import annotations

from dataclasses import dataclass, field, fields
from typing import Any

from urdfkb.pipeline.knowledge import reasoning
from urdfkb.pipeline.abstraction.components import BodyPart, Component, FingerFact
from urdfkb.pipeline.abstraction.stages import body as body_stage
from urdfkb.pipeline.abstraction.stages.attachment import SubChain
from urdfkb.pipeline.abstraction.stages.classification import Typed
from urdfkb.pipeline.abstraction.stages.grouping import Group
from urdfkb.pipeline.abstraction.structure import ToolStructure

_LASTS = {"lasts": True}


def _lasting(default: Any = None, factory: Any = None) -> Any:
    """A field kept from pass to pass."""
    if factory is not None:
        return field(default_factory=factory, metadata=_LASTS)
    return field(default=default, metadata=_LASTS)


@dataclass
class Findings:
    """What the steps have found about one robot so far (lasting fields) and in the current pass."""

    # lasting: the robot's components so far (a device pass adds its own, the body pass locates them)
    components: list[Component] = _lasting(factory=list)
    # lasting, from the robot's shape (the shape step)
    hand_mounts: dict[str, str] = _lasting(factory=dict)  # leaf of a hand or gripper → its hand's mount
    feet: frozenset[str] = _lasting(frozenset())  # limb tips the robot stands on: never tools
    body_feet: frozenset[str] = _lasting(frozenset())  # feet that are a leg's last link or a body: body, unasked
    off_ends: frozenset[str] = _lasting(frozenset())  # leaves at no limb's end: never tools
    limb_ends: frozenset[str] = _lasting(frozenset())  # limbs' own last links, moving on their own joint: never sensors
    swinging: frozenset[str] = _lasting(frozenset())  # bars swinging beside the joint carrying a chain on: no sensors
    jaws: frozenset[str] = _lasting(frozenset())  # two leaves moving as mirror images on one link: never sensors
    frozen_tips: frozenset[str] = _lasting(frozenset())  # tips of fingers written fixed: never sensors, a hand's
    rods: frozenset[str] = _lasting(frozenset())  # leaves whose body is a thin rod: never sensors
    struts: frozenset[str] = _lasting(frozenset())  # leaves drawn as their mirror twin holding a body up: no sensors
    rolling_ends: frozenset[str] = _lasting(frozenset())  # those of both that roll, and spinners on the trunk: never tools
    last_segments: frozenset[str] = _lasting(frozenset())  # limb ends that are the limb's last segment: never tools
    loop_frames: frozenset[str] = _lasting(frozenset())  # frames a closed kinematic loop is cut at: no component
    collision_volumes: frozenset[str] = _lasting(frozenset())  # leaves only adding to a body's collision shape
    palms: frozenset[str] = _lasting(frozenset())  # the bodies of the hands found: they carry tool frames and sensors
    declared_sensors: frozenset[str] = _lasting(frozenset())  # leaves the file declares a measuring sensor on
    # lasting, from identification
    claims: dict[str, str] = _lasting(factory=dict)  # leaf → kind answer (a Component subclass or NONE)
    shares: dict[str, float] = _lasting(factory=dict)  # leaf → the share of the votes its answer had
    # lasting: the body candidates' classes from the end-effector pass's reasoner run, for the body pass
    body_reasoned: body_stage.Reasoned | None = _lasting()
    body: list[BodyPart] = _lasting(factory=list)  # the robot's body parts (the body pass)
    # the current pass's
    leaves: list[str] = field(default_factory=list)  # the leaves this pass may claim
    chains: list[SubChain] = field(default_factory=list)  # selected leaves with their mounts
    pre: dict[str, Typed] = field(default_factory=dict)  # leaf → pre-class (sensors)
    groups: list[Group] = field(default_factory=list)  # the devices
    post: list[Typed] = field(default_factory=list)  # each device's class
    structures: list[ToolStructure] = field(default_factory=list)  # each tool's structure (end-effectors)
    inferred: list[reasoning.Inference] = field(default_factory=list)  # the reasoner's class per tool
    fingers: list[tuple[FingerFact, ...]] = field(default_factory=list)  # each tool's finger chains
    parts: dict[str, Typed] = field(default_factory=dict)  # member link → sub-part class
    found: list[Component] = field(default_factory=list)  # the devices this pass found
    candidates: list[body_stage.Chain] = field(default_factory=list)  # the body pass's candidate chains
    done: bool = False  # nothing (more) to abstract in this pass: its remaining steps are skipped

    def next_pass(self) -> Findings:
        """A fresh record for the next pass, keeping the lasting fields."""
        return Findings(**{f.name: getattr(self, f.name) for f in fields(self) if f.name in LASTING})


FIELDS = frozenset(f.name for f in fields(Findings))
LASTING = frozenset(f.name for f in fields(Findings) if f.metadata.get("lasts"))
