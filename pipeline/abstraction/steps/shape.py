"""The shape step: what the robot's shape settles before any question (pipeline.abstraction.structure)."""
from __future__ import annotations

from urdfkb.pipeline.abstraction.components import SENSOR
from urdfkb.pipeline.reading.evidence import LinkEvidence
from urdfkb.pipeline.abstraction.passes import step
from urdfkb.pipeline.abstraction.steps.context import Context
from urdfkb.pipeline.abstraction.steps.findings import Findings
from urdfkb.pipeline.abstraction.hands import (feet, frozen_fingertips, hand_mounts, hands, jaw_pairs, last_segments,
                                              limb_ends, off_limb_ends, on_feet, on_trunk, palm, rolling, spinning_low,
                                              spinning_on_trunk, swinging_leaves)
from urdfkb.pipeline.abstraction.frames import collision_volumes, is_frame, loop_closures, placing_joints, rods, struts
from urdfkb.pipeline.reading.tree import KinematicTree

_NO_FACTS = LinkEvidence()


@step("shape", makes=("hand_mounts", "feet", "body_feet", "off_ends", "limb_ends", "swinging", "jaws", "rolling_ends",
                      "last_segments", "frozen_tips", "rods", "struts", "loop_frames", "collision_volumes", "palms",
                      "declared_sensors"))
def shape(ctx: Context, found: Findings) -> None:
    """The leaves of hands and grippers (their fingers, a hand's drive, tool centre points) belong to the
    end-effector pass unless a simulator declares a sensor on them; limb tips the robot stands on are feet,
    never tools (a foot that moves on its own joint is the leg's last link, and one with a body of its own, a sole or
    a ball, is the leg's foot: part of the body, unasked, where the file declares no sensor on it), and
    neither are leaves at no limb's end: fixed to a body a limb goes on from (along an arm, on the trunk),
    or bodies beside a hand on the link it is mounted on, or frames on a foot's body (hands.on_feet: a toe's, a
    sole's). A limb's own last link moving on its joint, or the tip of
    a finger written fixed, or a bar swinging on its own joint beside the joint that carries a moving chain on,
    is never a sensor (hands.limb_ends, hands.swinging_leaves, hands.frozen_fingertips), nor is a body shaped as a thin
    rod (frames.rods: a standoff, a pole, an antenna) or drawn as its mirror twin that holds a body up (frames.struts:
    one of a pair of standoffs, the other carrying a plate), and the first two never a
    tool where the joint rolls (hands.rolling: turning through more than half a turn, or about the line out to the
    leaf: a bare arm's flange link, a wheel, a bar hinged on its own pin) or where the limb's own last link carries
    its mass far out for a jaw (hands.last_segments: a forearm on the elbow of an arm that ends in no tool), nor is a
    leaf spinning on its own joint from the trunk (hands.spinning_on_trunk: a wheel, a rotor, a thruster) or low
    down (hands.spinning_low: wheels on steering joints, bogies, casters).
    Frames where a closed loop is cut (frames.loop_closures), and leaves drawn at their parent's origin for collision
    checking alone (frames.collision_volumes), are part of no component."""
    robot = ctx.robot
    declared = {link for link, facts in robot.evidence.items() if facts.sensors}
    seen = hands(robot)
    mounts = hand_mounts(robot, seen)
    found.hand_mounts = _sensing_fingers(robot, mounts, declared)
    found.feet = feet(robot)
    found.body_feet = frozenset(f for f in found.feet if f not in declared
                                and (robot.edge_to(f).movable or _body(robot, f)))
    found.off_ends = off_limb_ends(robot, seen) | on_feet(robot, found.feet)
    found.limb_ends = limb_ends(robot) - declared
    found.swinging = swinging_leaves(robot) - declared
    found.jaws = jaw_pairs(robot) - declared
    found.frozen_tips = frozen_fingertips(robot) - declared
    found.rods = rods(robot) - declared
    found.struts = struts(robot) - declared
    found.rolling_ends = frozenset(leaf for leaf in found.limb_ends | found.swinging if rolling(robot, leaf)) \
        | spinning_on_trunk(robot) - declared | spinning_low(robot) - declared - set(found.hand_mounts)
    found.last_segments = last_segments(robot, found.limb_ends)
    found.loop_frames = loop_closures(robot) - declared
    found.collision_volumes = collision_volumes(robot) - declared
    found.palms = frozenset(link for structure, _ in seen for link in palm(robot, structure.fork))
    found.declared_sensors = _measuring(ctx, robot)
    ctx.trace({"key": "shape", "hands": sorted(found.hand_mounts), "feet": sorted(found.feet),
               "body_feet": sorted(found.body_feet),
               "off_ends": sorted(found.off_ends), "limb_ends": sorted(found.limb_ends),
               "swinging": sorted(found.swinging), "jaws": sorted(found.jaws),
               "rolling_ends": sorted(found.rolling_ends), "last_segments": sorted(found.last_segments),
               "frozen_tips": sorted(found.frozen_tips), "rods": sorted(found.rods), "struts": sorted(found.struts),
               "loop_frames": sorted(found.loop_frames), "collision_volumes": sorted(found.collision_volumes)})


def _body(tree: KinematicTree, link: str) -> bool:
    """The link is a body: it has geometry beyond a frame's mark, or mass (a foot's ball drawn as a dot)."""
    facts = tree.evidence.get(link)
    return not is_frame(tree, link) or bool(facts and facts.mass)


def _measuring(ctx: Context, tree: KinematicTree) -> frozenset[str]:
    """The leaves the file declares a simulator sensor on that the ontology aligns to a sensor class: a camera,
    ranging, inertial, force-torque... declaration is made for what measures. A contact declaration counts only on a
    leaf fixed to the trunk (hands.on_trunk) of a robot that rolls on wheels (hands.spinning_low): a bumper panel on
    its base. On a limb it also reports the collisions of a foot or a fingertip, and on a robot without wheels those
    of a drone's landing skid, so those are left to the model."""
    vocab = ctx.vocab
    if SENSOR not in vocab.kinds:
        return frozenset()
    top, contact = vocab.kinds[SENSOR].cls, vocab.declared_classes(["contact"])  # SDF's sensor type
    rolls, placing = bool(spinning_low(tree)), placing_joints(tree)

    def measures(leaf: str) -> bool:
        declared = vocab.declared_classes(s.sdf_type for s in tree.evidence.get(leaf, _NO_FACTS).sensors)
        bumper = rolls and on_trunk(tree, leaf, placing)
        return any(vocab.is_a(c, top) and (bumper or not any(vocab.is_a(c, k) for k in contact)) for c in declared)
    return frozenset(leaf for leaf in tree.leaves() if measures(leaf))


def _sensing_fingers(robot: KinematicTree, mounts: dict[str, str], declared: set[str]) -> dict[str, str]:
    """A hand's leaves (`mounts`: leaf → the hand's mount) but those the file declares sensors on, and the links
    whose children are all such declared leaves of one hand: a fingertip whose pads and tactile cells are all declared
    sensors ends its finger once the sensor pass has taken them, so the hand keeps a leaf there."""
    found = {leaf: mount for leaf, mount in mounts.items() if leaf not in declared}
    for leaf, mount in mounts.items():
        parent = robot.parent(leaf)
        if leaf in declared and parent is not None and parent not in found \
                and all(child in declared and mounts.get(child) == mount for child in robot.children(parent)):
            found[parent] = mount
    return found
