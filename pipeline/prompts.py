"""The questions the pipeline asks, rendered as (static system text, short user text, options).

Static parts (instructions, the definitions of the options at one taxonomy level) go in the
system text so the backend evaluates them once and reuses them from its KV cache; the user
text carries only what differs per question. Option definitions are the ontology's own
rdfs:comment, so the taxonomy, not this file, says what each class means. Link names in the
examples below are invented; none comes from a robot we score against.
"""
from __future__ import annotations

from typing import Sequence

from .llm.base import Question
from .ontology import Taxonomy

NONE_OF_THESE = "Other"
MAX_CHAIN = 4  # ancestors shown as context for a link

_PREAMBLE = (
    "You read the URDF of a robot: a tree of links (rigid bodies or coordinate frames) joined by joints. "
    "Link names are informal and abbreviated; the chain of parent links shows where a link sits."
)

_KINDS_HEAD = (
    _PREAMBLE
    + "\nDecide which kind of component a leaf link belongs to."
    + "\nKinds:\n"
)
_KINDS_OTHER = (
    f"- {NONE_OF_THESE}: none of these: actuators and emitters (motors, lights, loudspeakers, displays, "
    "projectors), fasteners, covers, cables, and purely virtual reference frames."
)
_KINDS_TAIL = "\nReply with the kind only."

_ROOT = (
    _PREAMBLE
    + "\nA {kind} device is fixed to the robot body at one link: its mount. Links between the mount and the"
    " device's own frames belong to the device (its housing, its frames); the mount itself is a body part"
    " (a base, torso, head, arm or wrist link, or a bracket that carries the device)."
    "\nGiven one link of a {kind} and its chain of ancestors, name the mount: the first ancestor that is"
    " not part of the device itself."
    "\nReply with the link name only."
)

_LEVEL = (
    _PREAMBLE
    + "\n{subject} Choose the most fitting kind of {concept}:\n{definitions}"
    "\nReply with the kind only."
)

_GROUP = (
    _PREAMBLE
    + "\nSeveral {kind} frames hang from nearby links. {guidance}"
    "\nGiven a new frame and the devices found so far, answer the device it belongs to, or {new} if it is"
    " a separate device."
    "\nReply with one of the given names only."
)
_GROUP_GUIDANCE = {
    "sensor": "Frames of one physical sensor (for example the colour and depth frames of one camera, or the"
    " body and optical frames of one scanner) share its name stem; two sensors of the same type (a front"
    " and a rear unit, a left and a right unit) are separate devices. Identical sensing elements that"
    " work together as one array (for example the capsules of one microphone array) may form one device.",
    "end_effector": "All frames of one gripper or hand (its palm, fingers, finger tips and tool frame) form"
    " one device; a left and a right gripper are separate devices.",
}
NEW_DEVICE = "new"


def chain_text(chain: Sequence[str]) -> str:
    """A link's ancestors, nearest first, shortened to MAX_CHAIN."""
    shown = list(chain[:MAX_CHAIN])
    return " < ".join(shown) + (" < ..." if len(chain) > MAX_CHAIN else "")


def definitions(tax: Taxonomy, names: Sequence[str]) -> str:
    """One line per option: its local name and the ontology's comment."""
    return "\n".join(f"- {n}: {tax.comment(n)}" for n in names)


def kind_question(tax: Taxonomy, kinds: Sequence[str], link: str, ancestors: Sequence[str], joint: str) -> Question:
    """Which kind of component (or none) a leaf link is part of."""
    system = _KINDS_HEAD + definitions(tax, kinds) + "\n" + _KINDS_OTHER + _KINDS_TAIL
    user = f"Leaf link: {link}\nParents: {chain_text(ancestors)}\nJoint to parent: {joint}"
    return Question(system, user, (*kinds, NONE_OF_THESE), key=f"identify:{link}")


def root_question(kind_label: str, link: str, ancestors: Sequence[str]) -> Question:
    """Which ancestor is the mount of the device that `link` belongs to."""
    system = _ROOT.format(kind=kind_label)
    user = f"Link: {link}\nAncestors, nearest first: {' < '.join(ancestors)}"
    return Question(system, user, tuple(ancestors), key=f"root:{link}")


def level_question(tax: Taxonomy, concept: str, subject: str, evidence: str, key: str) -> Question:
    """Pick among the direct subclasses of `concept` for one subject (a sub-chain, a link, a group)."""
    options = tax.subclasses(concept)
    if len(options) == 1:  # a lone subclass is no choice: offer stopping at the concept itself
        options = (*options, concept)
    system = _LEVEL.format(subject=subject, concept=tax.label(concept), definitions=definitions(tax, options))
    return Question(system, evidence, options, key=f"{key}@{concept}")


def group_question(kind: str, kind_label: str, frame: str, evidence: str, devices: Sequence[str]) -> Question:
    """Which of the devices found so far a frame belongs to, or a new one."""
    system = _GROUP.format(kind=kind_label, guidance=_GROUP_GUIDANCE[kind], new=NEW_DEVICE)
    user = f"New frame: {frame}{evidence}\nAnswer one of: {', '.join((*devices, NEW_DEVICE))}"
    return Question(system, user, (*devices, NEW_DEVICE), key=f"group:{frame}")
