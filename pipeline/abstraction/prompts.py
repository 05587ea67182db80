"""The questions the pipeline asks, rendered as (static system text, short user text, options).

Static parts (instructions, the definitions of the options at one taxonomy level) go in the
system text so the backend evaluates them once and reuses them from its KV cache; the user
text carries only what differs per question. Options are the classes' natural-language labels,
or their skos:altLabel where a short phrase answers the question better (a small model reads
"vision sensor" far better than "VisionSensor", and "color image" better than "RGB frame"); each
Choice maps them back to ontology local names. Definitions and examples are the ontology's own
rdfs:comment and skos:example, so the taxonomy, not this file, says what each class means.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence, TypeVar

from urdfkb.pipeline.abstraction.catalogue import Product
from urdfkb.pipeline.llm.base import Question
from urdfkb.pipeline.knowledge.ontology import Kind, Vocabulary

NONE = "none"  # identification: the leaf is part of no component
MAX_CHAIN = 4  # ancestors shown as context for a link
_Default = TypeVar("_Default", str, None)

_PREAMBLE = (
    "You read the URDF of a robot: a tree of links (rigid bodies or coordinate frames) joined by joints. "
    "Link names are informal and abbreviated; the chain of parent links shows where a link sits. "
    "Facts from the file may follow: a link's mesh file (often a product or part name) and its shape.\n"
)


@dataclass(frozen=True)
class Choice:
    """A question plus what each of its options means (an ontology class or a sentinel)."""

    question: Question
    meaning: dict[str, str]

    def meant(self, answer: str | None, default: _Default) -> str | _Default:
        """What an answer means: `default` for an abstention (None) or an answer outside the options."""
        return default if answer is None else self.meaning.get(answer, default)


def _definitions(vocab: Vocabulary, classes: Sequence[str]) -> str:
    lines = []
    for c in classes:
        example = vocab.example(c)
        lines.append(f"- {vocab.answer(c)}: {vocab.comment(c)}" + (f" Example: {example}" if example else ""))
    return "\n".join(lines)


def _class_choice(system: str, user: str, vocab: Vocabulary, classes: Sequence[str], key: str,
                  extra: dict[str, str] | None = None) -> Choice:
    meaning = {vocab.answer(c): c for c in classes} | (extra or {})
    return Choice(Question(system, user, tuple(meaning), key=key), meaning)


def chain_text(chain: Sequence[str]) -> str:
    """A link's ancestors, nearest first, shortened to MAX_CHAIN."""
    shown = list(chain[:MAX_CHAIN])
    return " < ".join(shown) + (" < ..." if len(chain) > MAX_CHAIN else "")


def product_text(vocab: Vocabulary, product: Product | None, below: str | None = None) -> str:
    """The catalogue product a link names, as a line of evidence ('' for none). `below`: the class a descent
    starts from; the product's kinds from there down are named in the words the questions offer (a
    microphone array is an "audio sensor > microphone array"), so the first answer is there to read."""
    if not product:
        return ""
    if below is None or product.cls == below or not vocab.is_a(product.cls, below):
        return f"\nProduct: {product.label} ({vocab.label(product.cls)})"
    path, cls = [], product.cls
    while cls != below:
        path.append(cls)
        cls = next(p for p in vocab.parents(cls) if vocab.is_a(p, below))
    return f"\nProduct: {product.label} ({' > '.join(vocab.answer(c) for c in reversed(path))})"


def kind_choice(vocab: Vocabulary, kinds: Sequence[str], link: str, ancestors: Sequence[str], joint: str,
                product: Product | None = None) -> Choice:
    """Which kind of component (or none) a leaf link is part of; `product`: the catalogue's, where it names one."""
    system = (
        _PREAMBLE + "Decide which kind of component a leaf link belongs to.\nKinds:\n" + _definitions(vocab, kinds)
        + f"\n- {NONE}: part of none of these: actuators and emitters (motors, lights, loudspeakers, displays,"
        " projectors), fasteners, covers, cables, and purely virtual reference frames."
        "\nSensors and their frames are fixed to their parent; a leaf that moves on a revolute, continuous or"
        " prismatic joint is a finger, a wheel or another moving part, not a sensor."
        "\nReply with the kind only."
    )
    user = f"Leaf link: {link}\nParents: {chain_text(ancestors)}\nJoint to parent: {joint}" + product_text(vocab, product)
    return _class_choice(system, user, vocab, kinds, f"identify:{link}", {NONE: NONE})


DRIVE_PART = "mechanism"  # the sensor check's answers that take a leaf off the sensors: a drive's part,
PASSIVE_PART = "passive part"  # or a part that senses nothing and that others locate or power


def sensor_check(link: str, shown: str, ancestors: Sequence[str], product: str = "") -> Question:
    """A second, differently framed look at a leaf identified as a sensor (`shown`: its name with its
    facts; `product`: product_text's line for the catalogue product it names, as identification showed it):
    what is it?"""
    system = (
        _PREAMBLE + "A leaf link taken for a sensor may instead be something else. Say what the leaf link is:"
        "\n- sensor: the frame of a device that measures: camera, laser scanner, sonar, IMU, touch pad, bumper,"
        " button, microphone, force sensor."
        "\n- emitter: a device that gives out light, sound or images: LED, lamp, loudspeaker, display or screen,"
        " projector."
        f"\n- {DRIVE_PART}: a part of a motor or drive: screw, gear, slider, spring, linkage, dummy or helper link"
        " of an actuator."
        "\n- reference frame: a virtual point used for looking, grasping or planning (a tool, flange or end-effector"
        " frame), with no device of its own."
        f"\n- {PASSIVE_PART}: a part that measures nothing itself: battery, standoff, spacer, mounting plate,"
        " fiducial marker or tag, reflector that other sensors locate."
        f"\nReply with one of: sensor, emitter, {DRIVE_PART}, reference frame, {PASSIVE_PART}."
    )
    user = f"Leaf link: {shown}\nParents: {chain_text(ancestors)}{product}"
    return Question(system, user, ("sensor", "emitter", DRIVE_PART, "reference frame", PASSIVE_PART),
                    key=f"check:{link}")


def root_question(kind: Kind, link: str, candidates: Sequence[str]) -> Question:
    """Which of the offered ancestors is the mount of the device that `link` belongs to (the kind's
    core:promptNoun names the device, its core:mountRule says what its mount is)."""
    kind_label = kind.noun
    system = (
        _PREAMBLE + f"A {kind_label} is fixed to the robot body at one link, its mount. The links between the"
        f" mount and the {kind_label}'s own frames belong to the {kind_label} (its housing, palm, fingers,"
        f" adapters and frames); {kind.mount_rule}"
        f"\nGiven one link of a {kind_label} and its ancestors, name the mount."
        "\nReply with the link name only."
    )
    user = f"Link: {link}\nAncestors, nearest first: {' < '.join(candidates)}"
    return Question(system, user, tuple(candidates), key=f"root:{link}")


def level_options(vocab: Vocabulary, concept: str, exclude: frozenset[str] = frozenset()) -> tuple[str, ...]:
    """The direct subclasses of `concept` the schema allows here."""
    return tuple(c for c in vocab.subclasses(concept) if c not in exclude)


def level_choice(vocab: Vocabulary, concept: str, framing: str, evidence: str, key: str,
                 exclude: frozenset[str] = frozenset(), stay: tuple[str, str] | None = None) -> Choice:
    """Pick among the allowed direct subclasses of `concept` for one subject (a sub-chain, a link, a group);
    `stay`: (answer, definition) of one more option, meaning `concept` itself (none of its kinds)."""
    options = level_options(vocab, concept, exclude)
    label = vocab.label(concept)
    system = (
        _PREAMBLE + framing.format(concept=label) + f" Choose the most fitting kind of {label}:\n"
        + _definitions(vocab, options) + (f"\n- {stay[0]}: {stay[1]}" if stay else "") + "\nReply with the kind only."
    )
    return _class_choice(system, evidence, vocab, options, f"{key}@{concept}", {stay[0]: concept} if stay else None)


RIGID_TOOL = ("rigid tool", "End effector in which nothing moves, that neither grasps nor has a hand's shape: a probe,"
              " a ball, a pointer, a plate.")  # offered for a tool whose structure shows no moving part


def device_name_question(frame: str, prefixes: Sequence[str]) -> Question:
    """Which beginning of a frame's name names the device it belongs to."""
    system = (
        _PREAMBLE + "A frame's name usually starts with the name of the device it belongs to, followed by words"
        " for the frame's role in that device (optical, frame, link, rgb, depth, ir, tip, tool, and left or"
        " right for the two eyes of one stereo camera). A number or a position word (front, rear, left,"
        " right) that tells apart separate units of the same type is part of the device name."
        "\nGive the device name: the beginning of the frame name that names the whole device, without the"
        " role words. Examples: mast_cam3_l_optical_frame -> mast_cam3; chest_rgbd_depth_optical_frame ->"
        " chest_rgbd; ultrasonic_2_link -> ultrasonic_2; RearBumperLeft_frame -> RearBumperLeft;"
        " claw_finger_1_tip_link -> claw.\nReply with the device name only."
    )
    return Question(system, f"Frame: {frame}", tuple(prefixes), key=f"device:{frame}")


def body_choice(vocab: Vocabulary, evidence: str, key: str) -> Choice:
    """Which body part (or none) a chain of moving joints is; `evidence` from stages.body."""
    parts = vocab.offered(vocab.body_classes)
    system = (
        _PREAMBLE + "Decide which part of the robot's body a chain of moving joints is. Each joint is given with"
        " its type and how it moves the robot at rest (x forward, y left, z up).\nParts:\n"
        + _definitions(vocab, parts)
        + f"\n- {NONE}: none of these: a mechanism of the device it carries (a tilting sensor mount, a bumper's"
        " switch) or a passive linkage.\nReply with the part only."
    )
    return _class_choice(system, evidence, vocab, parts, key, {NONE: NONE})


def side_question(label: str, left: Sequence[str], right: Sequence[str]) -> Question:
    """Which of two mirrored parts (their joints) the names call the robot's left; the options are their
    first joints, geometry's left one first."""
    system = (
        _PREAMBLE + "Robots often have body parts in mirrored pairs. Names usually tell the robot's left one from"
        " its right one (l/r, left/right, L/R, or a side letter in a prefix).\nReply with the first joint"
        " of the part on the robot's left."
    )
    user = f"Two {label} parts:\n- {left[0]}: {', '.join(left)}\n- {right[0]}: {', '.join(right)}"
    return Question(system, user, (left[0], right[0]), key=f"side:{left[0]}")
