"""Fixtures shared by the server tests and the benchmark: a hand-written PR2 abstraction, a live server."""
from __future__ import annotations

import socket
import threading
from contextlib import contextmanager

from waitress import create_server

from pipeline.components import END_EFFECTOR, SENSOR, Abstraction, Component, SubComponent


def _comp(name, kind, cls, conf, root, *subs):
    return Component(name, kind, cls, conf, root, tuple(SubComponent(l, c, s) for l, c, s in subs))


PR2 = Abstraction((
    _comp("kinect", SENSOR, "RGBDCamera", 0.93, "head_mount_link",
          ("head_mount_kinect_rgb_optical_frame", "RgbFrame", 0.9),
          ("head_mount_kinect_ir_optical_frame", "DepthFrame", 0.85),
          ("head_mount_kinect_ir_link", "SensorHousing", 0.8)),
    _comp("wide_stereo", SENSOR, "StereoCamera", 0.81, "double_stereo_link",
          ("wide_stereo_l_stereo_camera_optical_frame", "RgbFrame", 0.8),
          ("wide_stereo_r_stereo_camera_optical_frame", "RgbFrame", 0.8)),
    _comp("prosilica", SENSOR, "MonocularCamera", 0.42, "head_mount_link",
          ("head_mount_prosilica_optical_frame", "RgbFrame", 0.7)),
    _comp("r_forearm_cam", SENSOR, "MonocularCamera", 0.9, "r_forearm_roll_link",
          ("r_forearm_cam_optical_frame", "RgbFrame", 0.9)),
    _comp("base_laser", SENSOR, "Lidar", 0.95, "base_link", ("base_laser_link", "SensingElement", 0.9)),
    _comp("tilt_laser", SENSOR, "Lidar", 0.6, "laser_tilt_mount_link", ("laser_tilt_link", "SensingElement", 0.35)),
    _comp("imu", SENSOR, "IMU", 0.9, "torso_lift_link", ("imu_link", "SensingElement", 0.9)),
    _comp("r_gripper_accelerometer", SENSOR, "Accelerometer", 0.3, "r_gripper_palm_link",
          ("r_gripper_motor_accelerometer_link", "SensingElement", 0.3)),
    _comp("r_gripper", END_EFFECTOR, "ParallelGripper", 0.88, "r_wrist_roll_link",
          ("r_gripper_palm_link", "Palm", 0.9),
          ("r_gripper_tool_frame", "ToolCenterPoint", 0.9),
          ("r_gripper_l_finger_link", "Finger", 0.85),
          ("r_gripper_r_finger_link", "Finger", 0.85),
          ("r_gripper_l_finger_tip_link", "ContactSurface", 0.8),
          ("r_gripper_r_finger_tip_link", "ContactSurface", 0.8)),
), {"mode": "hand-written test fixture"})


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@contextmanager
def live(app):
    """Serve a WSGI app with waitress on 127.0.0.1 (free port) in a thread; yields the base URL."""
    server = create_server(app, host="127.0.0.1", port=0, threads=6)
    thread = threading.Thread(target=server.run, daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{server.effective_port}"
    finally:
        server.close()
        thread.join(5)
