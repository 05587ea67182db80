"""urdfkb.client against a live server on 127.0.0.1 holding PR2 with a hand-written body: one method per
bundled query, Python values, and the errors (down, too slow, unknown robot, refused query, token)."""
import socket
import time

import pytest

from tests.kb_fixtures import PR2_ARM, free_port, live, make_app, served
from urdfkb.client import (ArmEndEffector, BodyPart, CameraLink, ClientError, Joint, KnowledgeBase, LocatedComponent,
                           QueryFailed, ServerUnavailable, UnknownRobot, class_words)



@pytest.fixture(scope="module")
def url(whole_pr2_store):
    with served(whole_pr2_store) as base:
        yield base


@pytest.fixture
def kb(url):
    return KnowledgeBase(url + "/", timeout=10)  # a trailing slash is fine


def test_cameras_sensors_and_what_is_mounted_below(kb):
    cams = kb.cameras("pr2")
    assert all(isinstance(c, CameraLink) for c in cams)
    assert {(c.link, c.camera, c.cls) for c in cams if c.camera == "kinect"} == {
        ("head_mount_kinect_rgb_optical_frame", "kinect", "RGBDCamera"), ("head_mount_kinect_ir_optical_frame", "kinect", "RGBDCamera"),
        ("head_mount_kinect_ir_link", "kinect", "RGBDCamera")}
    assert {c.camera for c in cams} == {"kinect", "wide_stereo", "prosilica", "r_forearm_cam"}
    sensors = {s.name: s for s in kb.sensors("pr2")}
    assert len(sensors) == 8 and sensors["imu"].cls == "IMU" and sensors["imu"].mount == "torso_lift_link"
    assert sensors["kinect"].confidence == 0.93 and isinstance(sensors["kinect"].confidence, float)
    assert {m.name for m in kb.mounted_below("pr2", "head_mount_link")} == {"kinect", "prosilica"}
    assert kb.mounted_below("pr2", "no_such_link") == []


def test_end_effectors_review_and_components(kb):
    tools = {t.name: t for t in kb.end_effectors("pr2")}
    assert set(tools) == {"l_gripper", "r_gripper"}
    assert tools["r_gripper"].cls == "ParallelGripper" and tools["r_gripper"].tcp == "r_gripper_tool_frame"
    assert tools["r_gripper"].contacts == ("r_gripper_l_finger_tip_link", "r_gripper_r_finger_tip_link")
    review = kb.low_confidence("pr2")
    assert [(r.component, r.confidence, r.link, r.subpart) for r in review][:4] == [
        ("r_gripper_accelerometer", 0.3, "r_gripper_palm_link", False),
        ("r_gripper_accelerometer", 0.3, "r_gripper_motor_accelerometer_link", True),
        ("tilt_laser", 0.35, "laser_tilt_link", True), ("prosilica", 0.42, "head_mount_link", False)]
    assert len(kb.low_confidence("pr2", threshold=0.31)) == 2
    comps = {c.name: c for c in kb.components("pr2")}
    kinect = comps["kinect"]
    assert (kinect.cls, kinect.confidence, kinect.mount) == ("RGBDCamera", 0.93, "head_mount_link")
    assert {(s.cls, s.link) for s in kinect.subparts} == {("RgbFrame", "head_mount_kinect_rgb_optical_frame"),
                                                          ("DepthFrame", "head_mount_kinect_ir_optical_frame"),
                                                          ("SensorHousing", "head_mount_kinect_ir_link")}


def test_body_parts(kb):
    parts = {p.name: p for p in kb.body_parts("pr2")}
    assert parts["l_arm"] == BodyPart("l_arm", "Arm", "arm", "left", None, "torso_lift_link", 0.9,
                                      tuple(f"l_{j}_joint" for j in PR2_ARM))
    assert parts["head"].joints == ("head_pan_joint", "head_tilt_joint") and parts["head"].side is None
    assert parts["fr_caster_r_wheel"].parent == "base" and parts["fr_caster_r_wheel"].cls == "Wheel"
    assert parts["base"].label == "mobile base" and len(parts["base"].joints) == 4
    assert kb.body_parts("pr2_no_body") == []


def test_which_joints_move_the_left_arm(kb, pr2_tree):
    joints = kb.body_part_joints("pr2", "arm", side="left")
    assert [j.name for j in joints] == [f"l_{j}_joint" for j in PR2_ARM]

    def stored(e):  # the URDF's limits as the store keeps them: 4 places, no position limits on a continuous joint
        lower, upper = (round(x, 4) for x in e.limits) if e.limits else (None, None)
        return e.joint, e.joint_type, lower, upper, round(e.velocity, 4), round(e.effort, 4)

    urdf = {e.joint: e for e in pr2_tree.edges}
    assert [(j.name, j.type, j.lower, j.upper, j.velocity, j.effort) for j in joints] == [
        stored(urdf[j.name]) for j in joints]  # all seven with their limits
    assert joints[0] == Joint("l_shoulder_pan_joint", "revolute", -0.7146, 2.2854, 2.088, 30.0, (0.0, 0.0, 1.0), "l_arm", "left")
    assert all(isinstance(v, float) for j in joints for v in (j.velocity, j.effort, *j.axis))
    roll = joints[4]
    assert (roll.name, roll.type, roll.lower, roll.upper, roll.velocity) == ("l_forearm_roll_joint", "continuous", None, None, 3.6)
    assert [j.name for j in kb.body_part_joints("pr2", "Arm", side="RIGHT")] == [f"r_{j}_joint" for j in PR2_ARM]
    assert len(kb.body_part_joints("pr2", "arm")) == 14
    assert [j.name for j in kb.body_part_joints("pr2", "head")] == ["head_pan_joint", "head_tilt_joint"]
    with pytest.raises(ValueError, match="side"):
        kb.body_part_joints("pr2", "arm", side="port")


def test_what_is_on_the_head_and_at_the_end_of_an_arm(kb):
    head = kb.located_on("pr2", "head")
    assert all(isinstance(c, LocatedComponent) and c.part == "head" and c.side is None for c in head)
    assert {(c.name, c.cls, c.label) for c in head} == {("kinect", "RGBDCamera", "RGB-D camera"),
                                                        ("wide_stereo", "StereoCamera", "stereo camera"),
                                                        ("prosilica", "MonocularCamera", "monocular camera")}
    assert {c.name for c in kb.located_on("pr2", "arm", side="left")} == {"l_gripper"}
    (right,) = kb.arm_end_effector("pr2", side="right")
    assert isinstance(right, ArmEndEffector) and (right.arm, right.side) == ("r_arm", "right")
    tool = right.end_effector
    assert tool is not None
    assert (tool.name, tool.cls, tool.label, tool.mount, tool.tcp) == (
        "r_gripper", "ParallelGripper", "parallel gripper", "r_wrist_roll_link", "r_gripper_tool_frame")
    assert tool.joints == tuple(sorted(f"r_gripper_{f}_joint" for f in ("l_finger", "r_finger", "l_finger_tip", "r_finger_tip")))
    assert [(a.arm, a.end_effector.name) for a in kb.arm_end_effector("pr2")] == [("l_arm", "l_gripper"), ("r_arm", "r_gripper")]
    assert kb.arm_end_effector("pr2_one_gripper", side="left") == [ArmEndEffector("l_arm", "left", None)]


def test_any_query_by_name_and_the_robots(kb):
    assert set(kb.robots()) == {"pr2", "pr2_one_gripper", "pr2_no_body"}
    rows = kb.query("located_on", "pr2", part="torso", side=None)
    assert {r["name"] for r in rows} == {"imu", "tilt_laser"} and all(isinstance(v, str) for r in rows for v in r.values())


def test_refusals_are_clear(kb, url):
    with pytest.raises(UnknownRobot, match="'nao'") as e:
        kb.cameras("nao")
    assert e.value.robot == "nao" and url in str(e.value) and isinstance(e.value, LookupError)
    with pytest.raises(QueryFailed, match="decimal") as failed:
        kb.query("low_confidence", "pr2", threshold="abc")
    assert failed.value.status == 400 and failed.value.query == "low_confidence"
    with pytest.raises(QueryFailed, match="no query 'toasters'") as failed:  # a server without that query: not a robot problem
        kb.query("toasters", "pr2")
    assert failed.value.status == 404 and not isinstance(failed.value, UnknownRobot)
    with pytest.raises(ValueError):
        kb.cameras("")
    with pytest.raises(ValueError):
        KnowledgeBase("127.0.0.1:8000")


def test_a_server_that_is_down_or_silent():
    down = f"http://127.0.0.1:{free_port()}"  # nothing listens there
    with pytest.raises(ServerUnavailable, match="refused") as e:
        KnowledgeBase(down).body_parts("pr2")
    assert e.value.url == down and down in str(e.value) and isinstance(e.value, ClientError)
    with socket.socket() as silent:  # accepts connections (the backlog) but never answers
        silent.bind(("127.0.0.1", 0))
        silent.listen(1)
        slow = f"http://127.0.0.1:{silent.getsockname()[1]}"
        start = time.monotonic()
        with pytest.raises(ServerUnavailable, match="0.5 s|in time") as e:
            KnowledgeBase(slow, timeout=0.5).cameras("pr2")
        assert time.monotonic() - start < 5 and slow in str(e.value)


def test_bearer_token(whole_pr2_store):
    """Behind a proxy that wants a token: sent when given, and a refusal is a QueryFailed with the proxy's reason."""
    app, jobs = make_app(whole_pr2_store)

    def proxy(environ, start_response):
        if environ.get("HTTP_AUTHORIZATION") != "Bearer s3cret":
            start_response("401 Unauthorized", [("Content-Type", "text/plain")])
            return [b"token required"]
        return app(environ, start_response)

    try:
        with live(proxy) as base:
            assert [j.name for j in KnowledgeBase(base, token="s3cret").body_part_joints("pr2", "head")] == [
                "head_pan_joint", "head_tilt_joint"]
            for token in (None, "wrong"):
                with pytest.raises(QueryFailed, match="HTTP 401: token required") as e:
                    KnowledgeBase(base, token=token).cameras("pr2")
                assert e.value.status == 401
    finally:
        jobs.shutdown()


def test_a_redirect_is_never_followed_with_the_token():
    """A server answering 302 to another origin: the client raised nothing and sent its token there."""
    seen = []

    def elsewhere(environ, start_response):
        seen.append(environ.get("HTTP_AUTHORIZATION"))
        start_response("200 OK", [("Content-Type", "application/json")])
        return [b"[]"]

    with live(elsewhere) as other:
        def redirecting(environ, start_response):
            start_response("302 Found", [("Location", f"{other}/robots")])
            return [b""]

        with live(redirecting) as base:
            with pytest.raises(QueryFailed, match=f"HTTP 302: redirected to '{other}/robots'") as e:
                KnowledgeBase(base, token="s3cret").robots()
    assert e.value.status == 302 and seen == []


def test_class_words():
    assert [class_words(c) for c in ("MonocularCamera", "RGBDCamera", "IMU", "MobileBase")] == [
        "monocular camera", "RGBD camera", "IMU", "mobile base"]
