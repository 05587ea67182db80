"""Generated hosts that carry a part, each a whole robot with its truth (schema of ../shared/spec/evaluation.md).

- wrist: a six-joint arm on a fixed pedestal; a tool part on its flange `tool0`, a sensor part on a bracket of
  the last wrist link; beside it, a generic gripper on the flange (for sensor parts) or a wrist camera (for tools).
- head: a torso lift with a pan-tilt head and a six-joint arm; a sensor part on the head, a tool part on the
  arm's flange; beside it, a torso IMU and a generic gripper (sensor parts) or a head camera (tools).
- base: a differential-drive base with a ball caster, an IMU and a 2D laser; a sensor part on the top plate, a
  tool part on the flange of a five-joint arm on the base.
- pair (parts whose macro takes a name): two copies named left and right, sensors at the base's front
  corners, tools on the two arms of a torso.
Host links have the names robots commonly give them; the generic devices beside the part are
written here (not taken from any public description).
"""
from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field

from benchmarks.parts.library import Instance, Part, gazebo_elements, joint_element, link_element

HOSTS = ("wrist", "head", "base", "pair")
OPTICAL = (-math.pi / 2, 0.0, -math.pi / 2)


@dataclass
class Robot:
    """A URDF under construction with its truth."""

    name: str
    links: list[ET.Element] = field(default_factory=list)
    joints: list[ET.Element] = field(default_factory=list)
    gazebo: list[ET.Element] = field(default_factory=list)
    components: list[dict] = field(default_factory=list)
    body: list[dict] = field(default_factory=list)
    ignore_joints: list[str] = field(default_factory=list)
    mounted: list[tuple[Instance, str]] = field(default_factory=list)  # each part instance and the link it is fixed to

    def link(self, name: str, **body) -> str:
        self.links.append(link_element(name, body))
        return name

    def joint(self, name: str, parent: str, child: str, kind: str = "fixed", **spec) -> str:
        self.joints.append(joint_element({"name": name, "parent": parent, "child": child, "type": kind, **spec}))
        return name

    def chain(self, parent: str, names: list[tuple[str, str]], axes: list, lengths: list[float],
              body=(0.06, 0.1)) -> list[str]:
        """A serial chain of revolute joints from `parent`: (link, joint) names, one axis and length each."""
        joints = []
        for (link, joint), axis, length in zip(names, axes, lengths):
            self.link(link, cylinder=[body[0], max(length, body[1])], mass=1.0)
            joints.append(self.joint(joint, parent, link, "revolute", xyz=(0, 0, length), axis=axis,
                                     limit=(-2.9, 2.9)))
            parent = link
        return joints

    def mount(self, inst: Instance, parent: str, xyz=(0, 0, 0), rpy=(0, 0, 0)) -> None:
        """The part instance fixed to `parent`, with its truth."""
        for name in inst.link_names:
            self.links.append(link_element(name, inst.links.get(name)))
        self.joint(f"{inst.root}_mount_joint", parent, inst.root, xyz=xyz, rpy=rpy)
        for j in inst.joints:
            self.joints.append(joint_element(j))
        self.gazebo += [gazebo_elements(g) for g in inst.gazebo]
        self.components += [{**c, "roots": [parent if r == "{mount}" else r for r in c["roots"]]} for c in inst.truth]
        self.ignore_joints += inst.ignore_joints
        self.mounted.append((inst, parent))

    def part_components(self) -> list[dict]:
        """The truth components of the mounted parts (not the host's own devices)."""
        ids = {c["id"] for inst, _ in self.mounted for c in inst.truth}
        return [c for c in self.components if c["id"] in ids]

    def urdf(self) -> bytes:
        robot = ET.Element("robot", name=self.name)
        robot.extend(self.links + self.joints + self.gazebo)
        ET.indent(robot)
        return ET.tostring(robot, encoding="utf-8", xml_declaration=True)

    def truth(self, urdf_path: str) -> dict:
        return {"robot": self.name, "urdf": urdf_path, "ignore": [], "components": self.components,
                "body": {"ignore_joints": self.ignore_joints, "parts": self.body}}


# ---- generic devices beside the part ---------------------------------------------------------

def camera(r: Robot, stem: str, parent: str, xyz) -> None:
    """A plain colour camera: a housing and its optical frame, a simulator camera publishing in it."""
    housing = r.link(f"{stem}_link", box=[0.03, 0.08, 0.03], mass=0.1)
    r.joint(f"{stem}_joint", parent, housing, xyz=xyz)
    optical = r.link(f"{stem}_optical_frame")
    r.joint(f"{stem}_optical_joint", housing, optical, rpy=OPTICAL)
    r.gazebo.append(gazebo_elements({"reference": housing, "sensors": [{"type": "camera", "name": stem}],
                                     "plugin": {"name": f"{stem}_controller", "filename": "libgazebo_ros_camera.so",
                                                "tags": {"frameName": optical}}}))
    r.components.append({"id": stem, "kind": "sensor", "classes": ["MonocularCamera"], "roots": [parent],
                         "leaves": [optical], "subparts": {optical: ["RgbFrame"]}})


def imu(r: Robot, stem: str, parent: str, xyz) -> None:
    link = r.link(f"{stem}_link", box=[0.02, 0.02, 0.01], mass=0.01)
    r.joint(f"{stem}_joint", parent, link, xyz=xyz)
    r.gazebo.append(gazebo_elements({"reference": link, "sensors": [{"type": "imu", "name": stem}]}))
    r.components.append({"id": stem, "kind": "sensor", "classes": ["IMU"], "roots": [parent], "leaves": [link]})


def laser(r: Robot, stem: str, parent: str, xyz) -> None:
    link = r.link(f"{stem}_link", cylinder=[0.03, 0.05], mass=0.2)
    r.joint(f"{stem}_joint", parent, link, xyz=xyz)
    r.gazebo.append(gazebo_elements({"reference": link, "sensors": [{"type": "ray", "name": stem}],
                                     "plugin": {"name": f"{stem}_controller", "filename": "libgazebo_ros_laser.so",
                                                "tags": {"frameName": link}}}))
    r.components.append({"id": stem, "kind": "sensor", "classes": ["Lidar"], "roots": [parent], "leaves": [link]})


def gripper(r: Robot, stem: str, parent: str) -> None:
    """Two fingers sliding towards each other on a gripper body."""
    body = r.link(f"{stem}_base_link", box=[0.06, 0.12, 0.05], mass=0.5)
    r.joint(f"{stem}_base_joint", parent, body, xyz=(0, 0, 0.01))
    fingers = []
    for side, sign in (("left", 1), ("right", -1)):
        finger = r.link(f"{stem}_{side}_finger_link", box=[0.02, 0.01, 0.05], mass=0.05)
        r.joint(f"{stem}_{side}_finger_joint", body, finger, "prismatic", xyz=(0, sign * 0.04, 0.07),
                axis=(0, -sign, 0), limit=(0.0, 0.04),
                **({"mimic": [f"{stem}_left_finger_joint", 1]} if side == "right" else {}))
        fingers.append(finger)
    r.components.append({"id": stem, "kind": "end_effector", "classes": ["ParallelGripper"], "roots": [parent],
                         "leaves": fingers})


# ---- hosts ----------------------------------------------------------------------------------

ARM6 = [("shoulder_link", "shoulder_pan_joint"), ("upper_arm_link", "shoulder_lift_joint"),
        ("forearm_link", "elbow_joint"), ("wrist_1_link", "wrist_1_joint"),
        ("wrist_2_link", "wrist_2_joint"), ("wrist_3_link", "wrist_3_joint")]
AXES6 = [(0, 0, 1), (0, 1, 0), (0, 1, 0), (0, 1, 0), (0, 0, 1), (0, 1, 0)]
LENGTHS6 = [0.16, 0.14, 0.42, 0.39, 0.11, 0.09]


def _arm(r: Robot, parent: str, prefix: str, side: str | None = None) -> str:
    """A six-joint arm from `parent` ending in a flange frame; returns the flange."""
    joints = r.chain(parent, [(prefix + a, prefix + b) for a, b in ARM6], AXES6, LENGTHS6)
    flange = r.link(prefix + "tool0")
    r.joint(prefix + "wrist_3_link-tool0_fixed_joint", prefix + "wrist_3_link", flange, xyz=(0, 0.08, 0),
            rpy=(-math.pi / 2, 0, 0))
    r.body.append({"id": prefix + "arm", "classes": ["Arm"], "roots": [parent], "joints": joints,
                   **({"side": side} if side else {})})
    return flange


def _tool_roots(r: Robot, flange: str, last: str) -> None:
    """A device on a flange frame or bracket may be read as mounted on the link that carries it too."""
    for c in r.components:
        if flange in c["roots"] and last not in c["roots"]:
            c["roots"].append(last)


def wrist(part: Part) -> Robot:
    r = Robot(f"{part.key}__wrist")
    world = r.link("world")
    base = r.link("base_link", cylinder=[0.08, 0.1], mass=4.0)
    r.joint("world_joint", world, base)
    flange = _arm(r, base, "")
    inst = part.instance()
    if part.place == "tool":
        r.mount(inst, flange)
        camera(r, "wrist_camera", "wrist_3_link", (0.06, 0.0, 0.05))
        _tool_roots(r, flange, "wrist_3_link")
    else:
        bracket = r.link("camera_bracket_link", box=[0.05, 0.02, 0.04], mass=0.05)
        r.joint("camera_bracket_joint", "wrist_3_link", bracket, xyz=(0.07, 0.0, 0.03))
        r.mount(inst, bracket, xyz=(0.02, 0, 0.02))
        _tool_roots(r, bracket, "wrist_3_link")
        gripper(r, "gripper", flange)
        _tool_roots(r, flange, "wrist_3_link")
    return r


def head(part: Part) -> Robot:
    r = Robot(f"{part.key}__head")
    base = r.link("base_link", box=[0.4, 0.4, 0.3], mass=20.0)
    torso = r.link("torso_lift_link", box=[0.2, 0.3, 0.6], mass=8.0)
    lift = r.joint("torso_lift_joint", base, torso, "prismatic", xyz=(0, 0, 0.5), axis=(0, 0, 1), limit=(0, 0.35))
    pan = r.link("head_pan_link", cylinder=[0.04, 0.05], mass=0.5)
    tilt = r.link("head_tilt_link", box=[0.1, 0.2, 0.1], mass=1.0)
    r.joint("head_pan_joint", torso, pan, "revolute", xyz=(0, 0, 0.4), axis=(0, 0, 1), limit=(-2.8, 2.8))
    r.joint("head_tilt_joint", pan, tilt, "revolute", xyz=(0.02, 0, 0.06), axis=(0, 1, 0), limit=(-0.8, 1.2))
    r.body += [{"id": "torso", "classes": ["Torso"], "roots": [base], "joints": [lift]},
               {"id": "head", "classes": ["Head"], "roots": [torso], "joints": ["head_pan_joint", "head_tilt_joint"]}]
    imu(r, "torso_imu", torso, (0, 0, 0.1))
    shoulder = r.link("arm_mount_link", box=[0.05, 0.05, 0.05])
    r.joint("arm_mount_joint", torso, shoulder, xyz=(0.1, -0.2, 0.3), rpy=(math.pi / 2, 0, 0))
    flange = _arm(r, shoulder, "arm_")
    inst = part.instance()
    if part.place == "tool":
        r.mount(inst, flange)
        camera(r, "head_camera", tilt, (0.06, 0, 0.04))
    else:
        r.mount(inst, tilt, xyz=(0.06, 0, 0.05))
        gripper(r, "gripper", flange)
    _tool_roots(r, flange, "arm_wrist_3_link")
    return r


def _mobile_base(r: Robot) -> str:
    footprint = r.link("base_footprint")
    base = r.link("base_link", box=[0.5, 0.4, 0.2], mass=25.0)
    r.joint("base_footprint_joint", footprint, base, xyz=(0, 0, 0.1))
    for side, y in (("left", 0.22), ("right", -0.22)):
        wheel = r.link(f"{side}_wheel_link", cylinder=[0.08, 0.04], mass=1.0)
        r.joint(f"{side}_wheel_joint", base, wheel, "continuous", xyz=(0, y, -0.02), rpy=(-math.pi / 2, 0, 0),
                axis=(0, 0, 1))
        r.body.append({"id": f"{side}_wheel", "classes": ["Wheel"], "roots": [base],
                       "joints": [f"{side}_wheel_joint"], "side": side})
    caster = r.link("caster_link", sphere=0.04, mass=0.2)
    r.joint("caster_joint", base, caster, xyz=(-0.2, 0, -0.06))
    r.body.insert(0, {"id": "base", "classes": ["MobileBase"], "roots": [], "joints": [], "links": [base]})
    imu(r, "imu", base, (0, 0, 0.05))
    laser(r, "base_laser", base, (0.2, 0, 0.13))
    return base


def base(part: Part) -> Robot:
    r = Robot(f"{part.key}__base")
    chassis = _mobile_base(r)
    inst = part.instance()
    if part.place == "tool":
        arm_base = r.link("arm_base_link", box=[0.1, 0.1, 0.05], mass=1.0)
        r.joint("arm_base_joint", chassis, arm_base, xyz=(0.1, 0, 0.12))
        names = [(f"arm_link{i}", f"arm_joint{i}") for i in range(1, 6)]
        joints = r.chain(arm_base, names, AXES6[:4] + [(0, 0, 1)], [0.08, 0.05, 0.25, 0.25, 0.07])
        flange = r.link("arm_flange")
        r.joint("arm_flange_joint", "arm_link5", flange, xyz=(0, 0, 0.04))
        r.body.append({"id": "arm", "classes": ["Arm"], "roots": [arm_base], "joints": joints})
        r.mount(inst, flange)
        _tool_roots(r, flange, "arm_link5")
    else:
        plate = r.link("top_plate_link", box=[0.4, 0.35, 0.01], mass=1.0)
        r.joint("top_plate_joint", chassis, plate, xyz=(0, 0, 0.2))
        r.mount(inst, plate, xyz=(0.1, 0, 0.05))
    return r


def pair(part: Part) -> Robot:
    """Two copies named as the part's pair says (only for parts whose macro takes a name)."""
    if not part.pair:
        raise ValueError(f"{part.key}: its macro takes no name, so it has no left/right pair")
    r = Robot(f"{part.key}__pair")
    left, right = (part.instance(n) for n in part.pair)
    if part.place == "tool":
        base = r.link("base_link", box=[0.3, 0.5, 0.8], mass=30.0)
        for inst, side, y in ((left, "left", 0.25), (right, "right", -0.25)):
            shoulder = r.link(f"{side}_arm_mount", box=[0.05, 0.05, 0.05])
            r.joint(f"{side}_arm_mount_joint", base, shoulder, xyz=(0, y, 0.7), rpy=(-math.copysign(math.pi / 2, y), 0, 0))
            flange = _arm(r, shoulder, f"{side}_", side)
            r.mount(inst, flange)
            _tool_roots(r, flange, f"{side}_wrist_3_link")
    else:
        chassis = _mobile_base(r)
        for inst, y, yaw in ((left, 0.15, 0.5), (right, -0.15, -0.5)):
            r.mount(inst, chassis, xyz=(0.25, y, 0.12), rpy=(0, 0, yaw))
    return r


BUILD = {"wrist": wrist, "head": head, "base": base, "pair": pair}


def hosts_for(part: Part) -> tuple[str, ...]:
    """The hosts a part is mounted on: the pair host only where its macro takes a name."""
    return tuple(h for h in HOSTS if h != "pair" or part.pair)
