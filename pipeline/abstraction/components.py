"""What the abstraction pipeline produces: components, their sub-components, provenance.

These plain records are the one hand-over between the stages and everything downstream
(population, the result cache, the server). Class names are ontology local names.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, field, replace

SENSOR = "sensor"
END_EFFECTOR = "end_effector"
KINDS = (SENSOR, END_EFFECTOR)
SIDES = ("left", "right")


@dataclass(frozen=True)
class SubComponent:
    """One sub-link of a component, typed with its pre-classification class (Subpart branch)."""

    link: str
    cls: str
    confidence: float


@dataclass(frozen=True)
class FingerFact:
    """One finger chain of an end-effector, as its structure shows it (pipeline.abstraction.structure, pipeline.knowledge.reasoning);
    chains are named by their first link."""

    name: str
    drive: str                # the joint that hangs the chain on the tool and moves it
    chain_class: str          # PrismaticFingerChain, PivotingFingerChain or FrozenFingerChain
    thumb: bool               # the reasoner inferred ThumbChain
    opposes: tuple[str, ...]
    moves_with: tuple[str, ...]
    mimics: str | None


@dataclass(frozen=True)
class Component:
    """A physical device: its post-classification class, attachment root and sub-components."""

    name: str
    kind: str
    cls: str
    confidence: float
    root: str
    subcomponents: tuple[SubComponent, ...]
    fingers: tuple[FingerFact, ...] = ()
    joints: tuple[str, ...] = ()      # an end-effector's own movable joints (fingers, jaws)
    located_on: str | None = None     # the name of the BodyPart carrying its mount
    side: str | None = None           # "left"/"right" where it carries its body part's side
    kind_share: float = 1.0           # the share of the votes that took its leaves for its kind (confidence's factor)

    @property
    def links(self) -> tuple[str, ...]:
        return tuple(s.link for s in self.subcomponents)


@dataclass(frozen=True)
class BodyPart:
    """One part of the robot's body (an Arm, Leg, Head, Torso, Wheel or MobileBase) from the body pass:
    its movable joints (root-most first), the links they move, the link it hangs from."""

    name: str
    cls: str
    confidence: float
    root: str | None                  # isMountedOn: the parent link of its first joint (None: a base with no joints)
    joints: tuple[str, ...]
    links: tuple[str, ...]
    side: str | None = None           # "left" / "right" for a member of a mirrored pair
    parent: str | None = None         # the BodyPart it is a sub-component of (a wheel of the base), None: the robot


@dataclass(frozen=True)
class Held:
    """A component or body part held back for review before population (pipeline.knowledge.screen): one that broke
    the SHACL shapes, or a sensor the model hardly believes in. Not written; listed for review with the reasons,
    one line each ("CameraShape: comp_x hasOpticalFrame: ...", "SensorFloor: ...")."""

    name: str
    kind: str | None                  # its component kind; None: a body part
    cls: str
    links: tuple[str, ...]
    violations: tuple[str, ...]


@dataclass(frozen=True)
class Abstraction:
    """All components found in one robot, with how they were found, and those held back for review."""

    components: tuple[Component, ...] = ()
    provenance: dict[str, str] = field(default_factory=dict)
    body: tuple[BodyPart, ...] = ()
    held: tuple[Held, ...] = ()

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, data: dict) -> "Abstraction":
        comps = tuple(
            Component(**{**c, "subcomponents": tuple(SubComponent(**s) for s in c["subcomponents"]),
                         "fingers": tuple(_finger(f) for f in c.get("fingers", ())),
                         "joints": tuple(c.get("joints", ()))})
            for c in data["components"]
        )
        body = tuple(BodyPart(**{**b, "joints": tuple(b["joints"]), "links": tuple(b["links"])})
                     for b in data.get("body", ()))
        held = tuple(Held(**{**h, "links": tuple(h["links"]), "violations": tuple(h["violations"])})
                     for h in data.get("held", ()))
        return cls(comps, dict(data.get("provenance", {})), body, held)

    def with_provenance(self, notes: dict[str, str]) -> "Abstraction":
        """The same abstraction, its provenance updated with `notes`."""
        return replace(self, provenance={**self.provenance, **notes})


def _finger(data: dict) -> FingerFact:
    return FingerFact(**{**data, "opposes": tuple(data["opposes"]), "moves_with": tuple(data["moves_with"])})
