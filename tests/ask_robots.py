"""The robots questions in words are asked about (tests/test_ask.py, benchmarks/ask.py): PR2 with its whole body
(tests/kb_fixtures.PR2_WHOLE) and the TurtleBot3 Waffle Pi sample, a wheeled robot with no arm, with its
components and body written by hand after shared/eval/truth/turtlebot3_waffle_pi.yaml."""
from __future__ import annotations

from pathlib import Path

from tests.kb_fixtures import PR2_WHOLE, _comp
from urdfkb.pipeline.abstraction.components import SENSOR, Abstraction, BodyPart
from urdfkb.pipeline.reading.ingest import load_urdf

TURTLEBOT3_URDF = Path(__file__).resolve().parents[1] / "kb_server" / "samples" / "turtlebot3_waffle_pi.urdf"

TURTLEBOT3 = Abstraction((
    _comp("lds_lidar", SENSOR, "Lidar", 0.93, "base_link", ("base_scan", "SensingElement", 0.9)),
    _comp("imu", SENSOR, "IMU", 0.9, "base_link", ("imu_link", "SensingElement", 0.9)),
    _comp("pi_camera", SENSOR, "MonocularCamera", 0.88, "base_link", ("camera_rgb_optical_frame", "RgbFrame", 0.85)),
), {"mode": "hand-written test fixture"}, (
    BodyPart("base", "MobileBase", 0.95, None, (), ("base_link",)),
    BodyPart("wheel_left", "Wheel", 0.9, "base_link", ("wheel_left_joint",), ("wheel_left_link",), "left", "base"),
    BodyPart("wheel_right", "Wheel", 0.9, "base_link", ("wheel_right_joint",), ("wheel_right_link",), "right", "base"),
))


def store_ask_robots(store, pr2_tree) -> None:
    """PR2 (whole body) as "pr2" and the TurtleBot3 Waffle Pi as "turtlebot3"."""
    store.replace_robot("pr2", pr2_tree, PR2_WHOLE)
    store.replace_robot("turtlebot3", load_urdf(TURTLEBOT3_URDF), TURTLEBOT3)
