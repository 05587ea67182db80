"""Fixtures shared by the server tests and the benchmark: a hand-written PR2 abstraction, the app
through Flask's test client, and a live server for the tests where a real socket is the point."""
from __future__ import annotations

import shutil
import socket
import threading
from contextlib import contextmanager
from dataclasses import replace
from pathlib import Path

from waitress.server import create_server

from urdfkb.pipeline.abstraction.components import END_EFFECTOR, SENSOR, Abstraction, BodyPart, Component, SubComponent


def _comp(name, kind, cls, conf, root, *subs):
    return Component(name, kind, cls, conf, root, tuple(SubComponent(link, c, s) for link, c, s in subs))


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


PR2_ARM = ("shoulder_pan", "shoulder_lift", "upper_arm_roll", "elbow_flex", "forearm_roll", "wrist_flex", "wrist_roll")


def _arm(side: str) -> BodyPart:
    s = side[0]
    links = ("shoulder_pan", "shoulder_lift", "upper_arm_roll", "upper_arm", "elbow_flex", "forearm_roll", "forearm",
             "wrist_flex", "wrist_roll")
    return BodyPart(f"{s}_arm", "Arm", 0.9, "torso_lift_link", tuple(f"{s}_{j}_joint" for j in PR2_ARM),
                    tuple(f"{s}_{link}_link" for link in links), side)


# PR2's whole body as the body pass would give it (joints root-most first), and PR2 with it: every component
# of PR2 located on its body part, the right gripper's finger joints, and a left gripper on the left arm.
PR2_BODY = (
    BodyPart("base", "MobileBase", 0.95, "base_link", tuple(f"{c}_caster_rotation_joint" for c in ("fl", "fr", "bl", "br")),
             tuple(f"{c}_caster_rotation_link" for c in ("fl", "fr", "bl", "br"))),
    *(BodyPart(f"{c}_caster_{w}_wheel", "Wheel", 0.9, f"{c}_caster_rotation_link", (f"{c}_caster_{w}_wheel_joint",),
               (f"{c}_caster_{w}_wheel_link",), parent="base") for c in ("fl", "fr", "bl", "br") for w in "lr"),
    BodyPart("torso", "Torso", 0.85, "base_link", ("torso_lift_joint",),
             ("torso_lift_link", "l_torso_lift_side_plate_link", "r_torso_lift_side_plate_link")),
    BodyPart("head", "Head", 0.8, "torso_lift_link", ("head_pan_joint", "head_tilt_joint"),
             ("head_pan_link", "head_tilt_link", "head_plate_frame", "sensor_mount_link", "double_stereo_link", "head_mount_link")),
    _arm("right"),
    _arm("left"),
)
_LOCATED = {"kinect": "head", "wide_stereo": "head", "prosilica": "head", "r_forearm_cam": "r_arm", "base_laser": "base",
            "tilt_laser": "torso", "imu": "torso", "r_gripper_accelerometer": "r_arm", "r_gripper": "r_arm"}


def _fingers(s: str) -> tuple[str, ...]:
    return tuple(f"{s}_gripper_{f}_joint" for f in ("l_finger", "r_finger", "l_finger_tip", "r_finger_tip"))


def _located(c: Component) -> Component:
    part = _LOCATED[c.name]
    return replace(c, located_on=part, side="right" if part == "r_arm" else None,
                   joints=_fingers("r") if c.name == "r_gripper" else ())


PR2_WHOLE = Abstraction((
    *(_located(c) for c in PR2.components),
    replace(_comp("l_gripper", END_EFFECTOR, "ParallelGripper", 0.86, "l_wrist_roll_link",
                  ("l_gripper_palm_link", "Palm", 0.9),
                  ("l_gripper_tool_frame", "ToolCenterPoint", 0.9),
                  ("l_gripper_l_finger_link", "Finger", 0.85),
                  ("l_gripper_r_finger_link", "Finger", 0.85),
                  ("l_gripper_l_finger_tip_link", "ContactSurface", 0.8),
                  ("l_gripper_r_finger_tip_link", "ContactSurface", 0.8)),
            located_on="l_arm", side="left", joints=_fingers("l")),
), {"mode": "hand-written test fixture"}, PR2_BODY)


def store_whole_pr2(store, tree) -> None:
    """PR2 with its whole body (PR2_WHOLE), the same with nothing on its left arm, and one with no body."""
    store.replace_robot("pr2", tree, PR2_WHOLE)
    store.replace_robot("pr2_one_gripper", tree, replace(PR2_WHOLE, components=tuple(
        c for c in PR2_WHOLE.components if c.name != "l_gripper")))
    store.replace_robot("pr2_no_body", tree, PR2)


def copied(kb: Path, folder: Path) -> Path:
    """A copy of the closed store file `kb` (conftest's pr2_kb, whole_pr2_kb) in `folder`, to open and write to."""
    return Path(shutil.copy(kb, folder / kb.name))


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@contextmanager
def running(server):
    """Run a waitress server's loop in a thread for the block; then stop it: its task threads first,
    then its sockets (closed under the loop, which the loop's thread expects and ignores)."""
    stopping = threading.Event()

    def run():
        try:
            server.run()
        except (OSError, ValueError):  # select() on sockets closed under it: expected when stopping
            if not stopping.is_set():
                raise

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    try:
        yield server
    finally:
        stopping.set()
        server.task_dispatcher.shutdown()
        server.close()
        thread.join(5)


@contextmanager
def live(app):
    """Serve a WSGI app with waitress on 127.0.0.1 (free port) in a thread; yields the base URL."""
    with running(create_server(app, host="127.0.0.1", port=0, threads=6)) as server:
        yield f"http://127.0.0.1:{server.effective_port}"


@contextmanager
def served(store, **kw):
    """The server app over `store` (make_app, `kw` passed on) served live; yields the base URL and shuts the
    app's jobs down after."""
    app, jobs = make_app(store, **kw)
    try:
        with live(app) as base:
            yield base
    finally:
        jobs.shutdown()


def fake_runner(abstractions: dict | None = None, delay: float = 0.0, fail: Exception | None = None):
    """A runner for JobManager: the hand-written abstraction for known robots, none otherwise."""
    import time

    def run(tree, settings, progress):
        for i in range(3):
            progress("classify", i, 3)
            time.sleep(delay / 3)
        if fail is not None:
            raise fail
        return (abstractions or {}).get(tree.robot_name, Abstraction((), {"mode": "fake"}))

    return run


def make_app(store, runner=None, token=None, remote=None, **kw):
    """The server app over `store` with a fake runner (PR2 gets its hand-written abstraction)."""
    from urdfkb.kb_server.app import create_app
    from urdfkb.kb_server.jobs import JobManager

    jobs = JobManager(store, runner or fake_runner({"pr2": PR2}), remote)
    return create_app(store, jobs, token=token, **kw), jobs


def client(app):
    """`http`'s contract without a socket: call(method, path, data, headers) -> (status, content type,
    body) through Flask's test client (one per request, so threads may call it at once). Like
    urllib, a body without a Content-Type is sent as application/x-www-form-urlencoded."""
    def call(method: str, path: str, data: bytes | None = None, headers: dict | None = None):
        headers = dict(headers or {})
        if data is not None and not any(k.lower() == "content-type" for k in headers):
            headers["Content-Type"] = "application/x-www-form-urlencoded"
        r = app.test_client().open(path, method=method, data=data, headers=headers)
        return r.status_code, r.headers.get("Content-Type", ""), r.get_data()
    return call


def http(method: str, url: str, data: bytes | None = None, headers: dict | None = None, timeout: float = 30):
    """(status, content type, body bytes) of one request, error statuses included."""
    import urllib.error
    import urllib.request

    req = urllib.request.Request(url, data=data, method=method, headers=headers or {})
    try:
        with urllib.request.urlopen(req, timeout=timeout) as r:
            return r.status, r.headers.get("Content-Type", ""), r.read()
    except urllib.error.HTTPError as e:
        return e.code, e.headers.get("Content-Type", ""), e.read()


def multipart(fields: dict[str, str], files: dict[str, tuple[str, bytes]]) -> tuple[bytes, str]:
    """A multipart/form-data body and its content type."""
    boundary = "urdfkb-test-boundary"
    parts = []
    for k, v in fields.items():
        parts.append(f'--{boundary}\r\nContent-Disposition: form-data; name="{k}"\r\n\r\n{v}\r\n'.encode())
    for k, (fname, data) in files.items():
        parts.append(f'--{boundary}\r\nContent-Disposition: form-data; name="{k}"; filename="{fname}"\r\n'
                     f'Content-Type: application/xml\r\n\r\n'.encode() + data + b"\r\n")
    parts.append(f"--{boundary}--\r\n".encode())
    return b"".join(parts), f"multipart/form-data; boundary={boundary}"


def both_engines(store, robot: str, name: str, args: dict) -> tuple[list[str], list[dict], list[dict]]:
    """A bundled query on `robot` answered by the store (Oxigraph) and, independently, by rdflib over the
    robot's self-contained export: (variables, the store's rows, rdflib's rows), rows as {var: string}."""
    import rdflib

    from urdfkb.kb_server.queries import load_queries
    from urdfkb.pipeline.knowledge.namespaces import ROBOT, robot_iri

    text = load_queries()[name].bind(robot_iri(robot) + ROBOT, args)
    answer = store.query(text)
    # rdflib still tells "x" from "x"^^xsd:string (RDF 1.1 makes them one term): give it plain literals
    export = store.export(robot, "nt").replace(b"^^<http://www.w3.org/2001/XMLSchema#string>", b"")
    reference = rdflib.Graph().parse(data=export, format="nt").query(text)
    return answer.vars, answer.as_dicts(), [
        {v: (str(value) if (value := row.get(rdflib.Variable(v))) is not None else None) for v in answer.vars}
        for row in reference.bindings]
