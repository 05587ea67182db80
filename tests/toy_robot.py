"""tests/data/toy_robot.urdf, an invented robot (a lidar, an RGB-D camera on a mast, a gripper on an arm, two
drive wheels, a status light), and what a perfect model answers about it: the scripted model's rule."""
from __future__ import annotations

from pathlib import Path

from urdfkb.pipeline.llm.base import Question
from urdfkb.pipeline.knowledge.ontology import vocabulary
from urdfkb.pipeline.abstraction.prompts import NONE

TOY = Path(__file__).parent / "data" / "toy_robot.urdf"
TAX = vocabulary()
LABELS = {TAX.answer(c): c for c in TAX._order}  # answer phrase → class, for the scripted model

# What a perfect model would answer about the toy robot.
KIND = {"front_scanner": "sensor", "mast_rgbd_color_optical": "sensor", "mast_rgbd_depth_optical": "sensor",
        "claw_jaw_a": "end effector", "claw_jaw_b": "end effector", "claw_tcp": "end effector",
        "drive_wheel_left": "body part", "drive_wheel_right": "body part", "claw_status_light": NONE}
ROOT = {"front_scanner": "chassis", "mast_rgbd_color_optical": "mast", "mast_rgbd_depth_optical": "mast",
        "claw_jaw_a": "arm_flange", "claw_jaw_b": "arm_flange", "claw_tcp": "arm_flange"}
DEVICE = {"front_scanner": "front_scanner", "mast_rgbd_color_optical": "mast_rgbd", "mast_rgbd_depth_optical": "mast_rgbd"}
CLASS = {"pre:front_scanner": "Lidar", "pre:mast_rgbd_color_optical": "MonocularCamera",
         "pre:mast_rgbd_depth_optical": "DepthCamera", "post:mast_rgbd_color_optical": "RGBDCamera",
         "pre:claw_jaw_a": "ParallelGripper", "pre:claw_jaw_b": "ParallelGripper", "pre:claw_tcp": "ParallelGripper",
         "post:claw_jaw_a": "ParallelGripper",
         "part:mast_rgbd_body": "SensorHousing",
         "part:mast_rgbd_color_optical": "RgbFrame", "part:mast_rgbd_depth_optical": "DepthFrame",
         "part:claw_base": "Palm", "part:arm_flange": "ToolHousing", "part:claw_jaw_a": "Finger", "part:claw_jaw_b": "Finger",
         "part:claw_tcp": "ToolCenterPoint", "part:claw_status_light": "StructuralSubpart"}


def perfect(q: Question) -> str:
    stage, _, subject = q.key.partition(":")
    subject, _, concept = subject.partition("@")
    if stage == "identify":
        return KIND[subject]
    if stage == "root":
        return ROOT[subject]
    if stage == "device":
        return DEVICE.get(subject, subject)
    if stage == "check":
        return "sensor"
    if stage == "side":
        return q.options[0]  # the toy's names agree with its geometry
    if stage == "body":
        return "none"  # whatever structure leaves open is a mechanism
    target = CLASS[f"{stage}:{subject}"]
    return next(o for o in q.options if TAX.is_a(target, LABELS[o]))
