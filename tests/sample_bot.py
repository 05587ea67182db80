"""A hand-made robot for the population, export and SHACL tests: a tree with every joint type, its
abstraction (an RGB-D camera on a head, a gripper on a wrist), and link names that are hostile in an IRI."""
from __future__ import annotations

from urdfkb.pipeline.abstraction.components import Abstraction, Component, SubComponent
from urdfkb.pipeline.reading.tree import Edge, KinematicTree, Origin

ZERO = Origin((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
HOSTILE = ["base link", "a#b", "a/b", "50%", "%41", "a.b", "a%2Eb", "ünï€😀", 'say "hi"', "it's", "<x>&y",
           "back\\slash", "tab\there", "new\nline", "?q=1", "{}|^`", "link_x", "comp_x"]


def sample_tree(name="bot", links=None):
    """base_link with a head carrying an RGB-D camera, an arm with a gripper; every joint type."""
    spec = [("caster_joint", "planar", "base_link", "caster_link"),
            ("odom_joint", "floating", "base_link", "odom_link"),
            ("head_joint", "revolute", "base_link", "head_link"),
            ("cam_joint", "fixed", "head_link", "cam_link"),
            ("rgb_joint", "fixed", "cam_link", "cam_rgb_optical_frame"),
            ("depth_joint", "fixed", "cam_link", "cam_depth_optical_frame"),
            ("wrist_joint", "continuous", "base_link", "wrist_link"),
            ("finger_joint", "prismatic", "wrist_link", "finger_link"),
            ("tool_joint", "fixed", "wrist_link", "tool_frame")]
    names = links or ("base_link", *(child for _, _, _, child in spec))
    return KinematicTree(name, tuple(names), tuple(Edge(j, t, p, c, ZERO) for j, t, p, c in spec))


def sample_abstraction(camera_cls="RGBDCamera", rgb_cls="RgbFrame"):
    camera = Component("head camera", "sensor", camera_cls, 0.93, "head_link",
                       (SubComponent("cam_rgb_optical_frame", rgb_cls, 0.8),
                        SubComponent("cam_depth_optical_frame", "DepthFrame", 1.0)))
    gripper = Component("gripper", "end_effector", "ParallelGripper", 2 / 3, "wrist_link",
                        (SubComponent("finger_link", "Finger", 0.6), SubComponent("tool_frame", "ToolCenterPoint", 1)))
    return Abstraction((camera, gripper), {"model": "tiny-q4", "votes": "3", "favourite colour": "blue"})
