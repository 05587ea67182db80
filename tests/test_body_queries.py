"""The whole-body HRI queries (body_parts, body_part_joints, located_on, arm_end_effector) on PR2 with a
hand-written body: each one's expected answer, how a part is chosen by class and side, and an
independent engine's agreement."""
import json
import re
import urllib.parse
from decimal import Decimal

import pytest

from tests.kb_fixtures import PR2_ARM, PR2_BODY, both_engines, client, copied, make_app
from urdfkb.kb_server.queries import ParamError, run_named
from urdfkb.kb_server.store import Store
from urdfkb.pipeline.abstraction.components import Abstraction, BodyPart

R = "https://w3id.org/urdfkb/robot/pr2#"
C = "https://w3id.org/urdfkb/core#"


@pytest.fixture(scope="module")
def store(whole_pr2_kb, pr2_tree, tmp_path_factory):
    s = Store(copied(whole_pr2_kb, tmp_path_factory.mktemp("kb")), workers=1)
    # and one whose base stands for its chassis
    s.replace_robot("pr2_chassis", pr2_tree, Abstraction((), {}, (BodyPart("base", "MobileBase", 0.7, None, (), ("base_link",)),)))
    yield s
    s.close()


def rows(store, name, robot="pr2", **args):
    return run_named(store, name, robot, {k: str(v) for k, v in args.items()}).as_dicts()


def test_body_parts_with_class_side_and_joints(store):
    got = rows(store, "body_parts")
    parts: dict[str, dict] = {}
    for r in got:
        part = parts.setdefault(r["name"], {"class": r["class"].removeprefix(C), "label": r["classLabel"], "side": r.get("side"),
                                            "parent": r.get("parent"), "mount": r.get("mount"),
                                            "confidence": r["confidence"], "joints": []})
        part["joints"].append(r["joint"])
    assert set(parts) == {p.name for p in PR2_BODY}
    assert parts["l_arm"] == {"class": "Arm", "label": "arm", "side": "left", "parent": None, "mount": "torso_lift_link",
                              "confidence": "0.9", "joints": [f"l_{j}_joint" for j in PR2_ARM]}  # root-most first
    assert parts["r_arm"]["side"] == "right" and parts["r_arm"]["joints"] == [f"r_{j}_joint" for j in PR2_ARM]
    assert parts["head"] == {"class": "Head", "label": "head", "side": None, "parent": None, "mount": "torso_lift_link",
                             "confidence": "0.8", "joints": ["head_pan_joint", "head_tilt_joint"]}
    assert parts["base"]["class"] == "MobileBase" and parts["base"]["label"] == "mobile base"
    assert sorted(parts["base"]["joints"]) == sorted(f"{c}_caster_rotation_joint" for c in ("fl", "fr", "bl", "br"))
    assert parts["fl_caster_l_wheel"]["parent"] == R + "body_base"  # a wheel is reached through the base
    assert parts["fl_caster_l_wheel"]["joints"] == ["fl_caster_l_wheel_joint"]
    assert parts["torso"]["joints"] == ["torso_lift_joint"]
    assert [r["bodyPart"] for r in got] == sorted(r["bodyPart"] for r in got)
    # a part with no joint is one row without one; a robot without a body has none
    assert rows(store, "body_parts", "pr2_chassis") == [{"bodyPart": "https://w3id.org/urdfkb/robot/pr2_chassis#body_base",
                                                         "name": "base", "class": C + "MobileBase", "classLabel": "mobile base",
                                                         "confidence": "0.7"}]
    assert rows(store, "body_parts", "pr2_no_body") == []


def test_joints_of_the_left_arm_with_limits_and_axis(store):
    got = rows(store, "body_part_joints", part="arm", side="left")
    assert [r["joint"] for r in got] == [f"l_{j}_joint" for j in PR2_ARM]
    assert {(r["bodyPart"], r["name"], r["side"]) for r in got} == {(R + "body_l_arm", "l_arm", "left")}
    pan = got[0]
    assert pan["type"] == "revolute"
    assert (Decimal(pan["lower"]), Decimal(pan["upper"])) == (Decimal("-0.7146"), Decimal("2.2854"))
    assert (Decimal(pan["velocity"]), Decimal(pan["effort"])) == (Decimal("2.088"), Decimal("30"))
    assert tuple(Decimal(pan[a]) for a in ("axisX", "axisY", "axisZ")) == (0, 0, 1)
    roll = got[4]  # a continuous joint: no position limits, but speed and effort
    assert roll["joint"] == "l_forearm_roll_joint" and roll["type"] == "continuous"
    assert "lower" not in roll and "upper" not in roll and Decimal(roll["velocity"]) == Decimal("3.6")
    assert tuple(Decimal(roll[a]) for a in ("axisX", "axisY", "axisZ")) == (1, 0, 0)


def test_a_part_is_chosen_by_class_and_side(store):
    def joints(**args):
        return [r["joint"] for r in rows(store, "body_part_joints", **args)]

    assert joints(part="Arm", side="right") == [f"r_{j}_joint" for j in PR2_ARM]
    assert joints(part="ARM", side="Left") == joints(part="arm", side="left")
    assert joints(part="arm") == [f"l_{j}_joint" for j in PR2_ARM] + [f"r_{j}_joint" for j in PR2_ARM]  # side any: both
    assert joints(part="arm", side="") == joints(part="arm", side="any") == joints(part="arm")
    assert joints(part="head") == ["head_pan_joint", "head_tilt_joint"]
    assert joints(part="head", side="left") == []  # the head has no side
    assert sorted(joints(part="mobile base")) == sorted(joints(part="mobile_base")) == sorted(joints(part="MobileBase"))
    assert len(joints(part="wheel")) == 8
    assert len(joints(part="body part")) == 4 + 8 + 1 + 2 + 7 + 7  # every part
    assert joints(part="gripper") == joints(part="sensor") == joints(part="tentacle") == []  # not body part classes
    assert joints(part="arm", side="left") and rows(store, "body_part_joints", "pr2_no_body", part="arm") == []
    assert joints() == joints(part="BodyPart")  # the default: every part
    with pytest.raises(ParamError, match="no parameter colour"):
        rows(store, "body_part_joints", colour="red")
    hostile = 'arm")) } UNION { ?bodyPart ?p ?o } #'
    assert joints(part=hostile) == []  # one literal, not query text


def test_what_is_on_the_head_and_the_arms(store):
    def on(**args):
        return {(r["name"], r["class"].removeprefix(C), r["mount"]) for r in rows(store, "located_on", **args)}

    assert on(part="head") == {("kinect", "RGBDCamera", "head_mount_link"), ("wide_stereo", "StereoCamera", "double_stereo_link"),
                               ("prosilica", "MonocularCamera", "head_mount_link")}
    assert on(part="arm", side="right") == {("r_forearm_cam", "MonocularCamera", "r_forearm_roll_link"),
                                            ("r_gripper_accelerometer", "Accelerometer", "r_gripper_palm_link"),
                                            ("r_gripper", "ParallelGripper", "r_wrist_roll_link")}
    assert on(part="arm", side="left") == {("l_gripper", "ParallelGripper", "l_wrist_roll_link")}
    assert len(on(part="arm")) == 4
    assert on(part="torso") == {("imu", "IMU", "torso_lift_link"), ("tilt_laser", "Lidar", "laser_tilt_mount_link")}
    assert on(part="mobile base") == {("base_laser", "Lidar", "base_link")}
    assert on(part="wheel") == set() and on(part="head", side="right") == set()
    head = rows(store, "located_on", part="head")
    assert {(r["bodyPart"], r.get("side")) for r in head} == {(R + "body_head", None)}
    assert {r["classLabel"] for r in head} == {"RGB-D camera", "stereo camera", "monocular camera"}
    assert rows(store, "located_on", "pr2_no_body", part="head") == []


def test_the_end_effector_at_the_end_of_an_arm(store):
    (right,) = rows(store, "arm_end_effector", side="right")
    assert (right["arm"], right["armName"], right["side"]) == (R + "body_r_arm", "r_arm", "right")
    assert (right["endEffector"], right["name"], right["class"], right["classLabel"]) == (
        R + "comp_r_gripper", "r_gripper", C + "ParallelGripper", "parallel gripper")
    assert right["mount"] == "r_wrist_roll_link" and right["tcp"] == "r_gripper_tool_frame"
    assert sorted(right["contacts"].split()) == ["r_gripper_l_finger_tip_link", "r_gripper_r_finger_tip_link"]
    assert sorted(right["joints"].split()) == sorted(f"r_gripper_{f}_joint" for f in ("l_finger", "r_finger", "l_finger_tip", "r_finger_tip"))
    (left,) = rows(store, "arm_end_effector", side="left")
    assert left["name"] == "l_gripper" and left["tcp"] == "l_gripper_tool_frame"
    assert [r["name"] for r in rows(store, "arm_end_effector")] == ["l_gripper", "r_gripper"]
    # an arm that carries nothing is one row without an end-effector
    (bare,) = rows(store, "arm_end_effector", "pr2_one_gripper", side="left")
    assert bare["armName"] == "l_arm" and "endEffector" not in bare and not bare.get("contacts") and not bare.get("joints")
    assert rows(store, "arm_end_effector", "pr2_no_body") == []


@pytest.mark.parametrize("name,args", [("body_parts", {}), ("body_part_joints", {"part": "arm", "side": "left"}),
                                       ("body_part_joints", {"part": "bodypart"}),
                                       ("located_on", {"part": "arm"}),
                                       ("arm_end_effector", {})])
@pytest.mark.slow
def test_oxigraph_agrees_with_rdflib_on_the_export(store, name, args):
    """An independent engine (rdflib) over the robot's self-contained export gives the same rows in the same order."""
    variables, store_rows, rdflib_rows = both_engines(store, "pr2", name, args)

    def value(text):  # rdflib writes decimals in canonical form ("0.0" for "0"): compare them as numbers
        return Decimal(text) if re.fullmatch(r"-?[0-9]+(\.[0-9]+)?", text) else " ".join(sorted(text.split()))

    def norm(rows):
        return [tuple(value(r[v]) if r.get(v) is not None else None for v in variables) for r in rows]

    got, want = norm(store_rows), norm(rdflib_rows)
    assert got and sorted(got, key=str) == sorted(want, key=str)
    if name in ("body_parts", "body_part_joints"):  # the joint order is part of the answer
        assert [(r[0], r[variables.index("joint")]) for r in got] == [(r[0], r[variables.index("joint")]) for r in want]


def test_listed_and_served_over_http(store):
    app, jobs = make_app(store)
    api = client(app)
    status, _, out = api("GET", "/queries")
    listed = {q["name"]: q for q in json.loads(out)}
    assert {p["name"]: p["default"] for p in listed["body_part_joints"]["params"]} == {"part": "BodyPart", "side": "any"}
    assert {p["name"] for p in listed["located_on"]["params"]} == {"part", "side"}
    assert [p["name"] for p in listed["arm_end_effector"]["params"]] == ["side"] and listed["body_parts"]["params"] == []
    q = urllib.parse.urlencode({"robot": "pr2", "part": "arm", "side": "left"})
    status, ctype, out = api("GET", f"/queries/body_part_joints?{q}")
    assert status == 200 and ctype.startswith("application/sparql-results+json")
    assert len(json.loads(out)["results"]["bindings"]) == 7
    status, _, out = api("GET", "/queries/located_on?robot=pr2")  # every part
    assert status == 200 and len(json.loads(out)["results"]["bindings"]) == 10
    status, _, out = api("GET", "/queries/located_on?robot=pr2&part=head&colour=red")
    assert status == 400 and "no parameter colour" in json.loads(out)["error"]
    jobs.shutdown()
