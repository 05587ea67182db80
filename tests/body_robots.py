"""Random but plausible robots for the body pass, with the truth of what was built.

Names are meaningless (a seeded random stem per link and joint), so whatever a test asserts comes
from structure alone: wheeled mobile manipulators (drive wheels, optional casters that swivel, a
lift, a pan-tilt head with a camera, one or two arms ending in a two-jaw gripper) and legged robots
(two or four legs of 2-4 joints, an optional arm). Frames follow REP 103: x forward, y left, z up.
"""
from __future__ import annotations

import random
from dataclasses import dataclass, field

from tests.urdf_writer import Writer
from urdfkb.pipeline.abstraction.components import END_EFFECTOR, SENSOR, Component, SubComponent


@dataclass
class Part:
    cls: str
    joints: list[str]
    side: str | None = None


@dataclass
class Built:
    urdf: bytes
    parts: list[Part]
    components: list[Component]
    device_joints: dict[str, list[str]] = field(default_factory=dict)  # component name → its own joints
    located: dict[str, str] = field(default_factory=dict)             # component name → first joint of its part


def _arm(w: Writer, built: Built, mount: str, y: float, z: float, side: str | None) -> None:
    """A serial arm of 4-7 revolute joints ending in a two-jaw gripper (an end-effector)."""
    parent, joints = mount, []
    for i in range(w.rng.randint(4, 7)):
        child = w.link('<cylinder radius="0.04" length="0.2"/>')
        joints.append(w.joint("revolute", parent, child, (0.1 if i else 0, y if not i else 0, z if not i else 0.1),
                              (0, 1, 0) if i % 2 else (0, 0, 1)))
        parent = child
    palm = w.link('<box size="0.05 0.08 0.04"/>')
    w.joint("fixed", parent, palm, (0.05, 0, 0))
    jaws = [w.link('<box size="0.04 0.01 0.02"/>') for _ in range(2)]
    first = w.joint("prismatic", palm, jaws[0], (0.05, 0.02, 0), (0, 1, 0))
    second = w.joint("prismatic", palm, jaws[1], (0.05, -0.02, 0), (0, -1, 0), mimic=first)
    tcp = w.link()
    w.joint("fixed", palm, tcp, (0.08, 0, 0))
    name = f"gripper_{len(built.components)}"
    built.components.append(Component(name, END_EFFECTOR, "ParallelGripper", 1.0, parent,
                                      tuple(SubComponent(link, "Finger", 1.0) for link in (palm, *jaws, tcp))))
    built.device_joints[name] = [first, second]
    built.located[name] = joints[0]
    built.parts.append(Part("Arm", joints, side))


def wheeled(seed: int, head_camera: bool = True) -> Built:
    """A mobile manipulator: drive wheels (and casters), a lift carrying a head and one or two arms;
    without `head_camera`, the head carries no camera (a file that leaves it out)."""
    rng = random.Random(seed)
    w = Writer(rng)
    built = Built(b"", [], [])
    base = w.link('<box size="0.6 0.5 0.2"/>')
    wheels = []
    for y, side in ((0.25, "left"), (-0.25, "right")):
        wheel = w.link('<cylinder radius="0.08" length="0.04"/>')
        wheels.append(Part("Wheel", [w.joint("continuous", base, wheel, (0, y, -0.05), (0, 1, 0))], side))
    base_joints = []
    if rng.random() < 0.5:  # two casters, front and back, each a swivel carrying a wheel
        for x in (0.25, -0.25):
            fork, wheel = w.link(), w.link('<cylinder radius="0.03" length="0.02"/>')
            base_joints.append(w.joint("continuous", base, fork, (x, 0, -0.05)))
            wheels.append(Part("Wheel", [w.joint("continuous", fork, wheel, (-0.03, 0, -0.05), (0, 1, 0))]))
    lift = w.link('<box size="0.2 0.3 0.6"/>')
    lift_joint = w.joint("prismatic", base, lift, (0, 0, 0.3))
    built.parts.append(Part("Torso", [lift_joint]))
    pan, tilt, camera, optical = w.link(), w.link('<box size="0.1 0.2 0.1"/>'), w.link(), w.link()
    head = [w.joint("revolute", lift, pan, (0, 0, 0.4)), w.joint("revolute", pan, tilt, (0, 0, 0.05), (0, 1, 0))]
    w.joint("fixed", tilt, camera, (0.05, 0, 0))
    w.joint("fixed", camera, optical)
    if head_camera:
        built.components.append(Component("camera", SENSOR, "MonocularCamera", 1.0, tilt,
                                          (SubComponent(camera, "SensorHousing", 1.0), SubComponent(optical, "RgbFrame", 1.0))))
        built.located["camera"] = head[0]
    built.parts.append(Part("Head", head))
    arms = rng.random()
    if arms < 0.3:  # one arm on the base: the lift carries the head alone (a run the pass cuts after the lift)
        _arm(w, built, base, 0.0, 0.3, None)
    elif arms < 0.6:
        _arm(w, built, lift, 0.0, 0.2, None)
    else:
        _arm(w, built, lift, 0.2, 0.2, "left")
        _arm(w, built, lift, -0.2, 0.2, "right")
    built.parts.append(Part("MobileBase", base_joints))
    built.parts += wheels
    built.urdf = w.urdf()
    return built


def legged(seed: int, bare_feet: bool = False, frame_feet: bool = False) -> Built:
    """Two or four legs of 2-4 joints reaching the ground, and sometimes an arm on the back; `bare_feet`: no
    foot link fixed at the tips, so each leg's last moving link is its foot (a humanoid's ankle roll link);
    `frame_feet`: the foot fixed at each tip is a bare frame (a sole or contact frame), not a ball."""
    rng = random.Random(seed)
    w = Writer(rng)
    built = Built(b"", [], [])
    trunk = w.link('<box size="0.5 0.3 0.1"/>')
    joints_per_leg = rng.randint(2, 4)
    spots = [(0.0, 0.1, "left"), (0.0, -0.1, "right")] if rng.random() < 0.5 else \
        [(0.2, 0.1, "left"), (0.2, -0.1, "right"), (-0.2, 0.1, "left"), (-0.2, -0.1, "right")]
    for x, y, side in spots:
        parent, joints = trunk, []
        for i in range(joints_per_leg):
            child = w.link('<box size="0.03 0.03 0.2"/>')
            joints.append(w.joint("revolute", parent, child, (x, y, 0) if not i else (0, 0, -0.2),
                                  (1, 0, 0) if not i else (0, 1, 0)))
            parent = child
        if not bare_feet:
            foot = w.link() if frame_feet else w.link('<sphere radius="0.02"/>')
            w.joint("fixed", parent, foot, (0, 0, -0.2))
        built.parts.append(Part("Leg", joints, side))
    if rng.random() < 0.5:
        _arm(w, built, trunk, 0.0, 0.1, None)
    built.urdf = w.urdf()
    return built
