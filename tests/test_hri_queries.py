"""Each named HRI query's expected answer on PR2 with a hand-written abstraction; parameter safety."""
import json
import urllib.parse

import pytest

from tests.kb_fixtures import PR2, both_engines, client, copied, make_app
from urdfkb.kb_server.queries import ParamError, UnknownQuery, _parse, load_queries, run_named, run_named_query
from urdfkb.kb_server.store import Store, UnknownRobot
from urdfkb.settings import MAX_VOTES, REVIEW_THRESHOLD

R = "https://w3id.org/urdfkb/robot/pr2#"
C = "https://w3id.org/urdfkb/core#"


@pytest.fixture(scope="module")
def store(pr2_kb, pr2_tree, tmp_path_factory):
    s = Store(copied(pr2_kb, tmp_path_factory.mktemp("kb")), workers=0)
    s.replace_robot("pr2_bare", pr2_tree, None)  # same links, no components: must not leak into pr2's answers
    yield s
    s.close()


def rows(store, name, robot="pr2", **args):
    return run_named(store, name, robot, {k: str(v) for k, v in args.items()}).as_dicts()


def test_which_links_are_cameras(store):
    got = {(r["link"], r["class"].removeprefix(C)) for r in rows(store, "cameras")}
    assert got == {
        ("head_mount_kinect_rgb_optical_frame", "RGBDCamera"), ("head_mount_kinect_ir_optical_frame", "RGBDCamera"),
        ("head_mount_kinect_ir_link", "RGBDCamera"),
        ("wide_stereo_l_stereo_camera_optical_frame", "StereoCamera"),
        ("wide_stereo_r_stereo_camera_optical_frame", "StereoCamera"),
        ("head_mount_prosilica_optical_frame", "MonocularCamera"), ("r_forearm_cam_optical_frame", "MonocularCamera")}
    assert rows(store, "cameras", "pr2_bare") == []


def test_sensors_with_type_and_mount(store):
    got = {(r["sensor"].removeprefix(R), r["class"].removeprefix(C), r["mount"], r["confidence"]) for r in rows(store, "sensors")}
    assert got == {
        ("comp_kinect", "RGBDCamera", "head_mount_link", "0.93"),
        ("comp_wide_stereo", "StereoCamera", "double_stereo_link", "0.81"),
        ("comp_prosilica", "MonocularCamera", "head_mount_link", "0.42"),
        ("comp_r_forearm_cam", "MonocularCamera", "r_forearm_roll_link", "0.9"),
        ("comp_base_laser", "Lidar", "base_link", "0.95"),
        ("comp_tilt_laser", "Lidar", "laser_tilt_mount_link", "0.6"),
        ("comp_imu", "IMU", "torso_lift_link", "0.9"),
        ("comp_r_gripper_accelerometer", "Accelerometer", "r_gripper_palm_link", "0.3")}


def test_mounted_on_or_below_a_link(store):
    def below(link):
        return {r["component"].removeprefix(R) for r in rows(store, "mounted_below", link=link)}

    assert below("r_forearm_roll_link") == {"comp_r_forearm_cam", "comp_r_gripper", "comp_r_gripper_accelerometer"}
    assert below("head_mount_link") == {"comp_kinect", "comp_prosilica"}
    assert below("r_gripper_palm_link") == {"comp_r_gripper_accelerometer"}
    assert below("base_footprint") == {"comp_" + c.name for c in PR2.components}
    assert below("no_such_link") == set()


def test_end_effectors_with_tcp_and_contact_surfaces(store):
    (row,) = rows(store, "end_effectors")
    assert row["endEffector"] == R + "comp_r_gripper" and row["class"] == C + "ParallelGripper"
    assert row["mount"] == "r_wrist_roll_link" and row["tcp"] == "r_gripper_tool_frame"
    assert sorted(row["contacts"].split()) == ["r_gripper_l_finger_tip_link", "r_gripper_r_finger_tip_link"]


def test_low_confidence_for_review(store):
    got = [(r["individual"].removeprefix(R), r["confidence"], r["link"]) for r in rows(store, "low_confidence")]
    assert got == [("comp_r_gripper_accelerometer", "0.3", "r_gripper_palm_link"),
                   ("sub_r_gripper_accelerometer.r_gripper_motor_accelerometer_link", "0.3", "r_gripper_motor_accelerometer_link"),
                   ("sub_tilt_laser.laser_tilt_link", "0.35", "laser_tilt_link"),
                   ("comp_prosilica", "0.42", "head_mount_link")]
    assert len(rows(store, "low_confidence", threshold=0.31)) == 2
    assert rows(store, "low_confidence", threshold=0) == []


@pytest.mark.parametrize("name,args", [("cameras", {}), ("sensors", {}), ("mounted_below", {"link": "torso_lift_link"}),
                                       ("end_effectors", {}), ("low_confidence", {}), ("components", {})])
@pytest.mark.slow
def test_oxigraph_agrees_with_rdflib_on_the_export(store, name, args):
    """An independent engine (rdflib) over the robot's self-contained export gives the same rows."""
    variables, got, want = both_engines(store, "pr2", name, args)

    def norm(rows):
        return sorted((tuple(" ".join(sorted(r[v].split())) if r.get(v) is not None else None for v in variables)
                       for r in rows), key=str)

    assert norm(got) == norm(want)


def test_a_default_may_name_a_setting_filled_in_as_the_file_loads():
    (threshold,) = load_queries()["low_confidence"].params
    assert threshold.default == str(REVIEW_THRESHOLD)
    head = "SELECT ?x WHERE { $robot ?p ?x FILTER(?x < $t) }"
    assert _parse("q", "# param t: decimal = {MAX_VOTES} - t\n" + head).params[0].default == str(MAX_VOTES)
    with pytest.raises(ValueError, match="no setting NOPE in urdfkb.settings"):
        _parse("q", "# param t: decimal = {NOPE} - t\n" + head)


def test_parameters_are_typed_and_checked(store):
    with pytest.raises(ParamError, match="decimal"):
        rows(store, "low_confidence", threshold="0.5) } #")
    with pytest.raises(ParamError, match="needs parameter 'link'"):
        rows(store, "mounted_below")
    with pytest.raises(ParamError, match="no parameter colour"):
        rows(store, "cameras", colour="red")
    with pytest.raises(UnknownRobot):
        rows(store, "cameras", "nao")
    with pytest.raises(UnknownQuery):
        rows(store, "toasters")
    hostile = 'x" } UNION { ?component ?p ?o } #'
    assert rows(store, "mounted_below", link=hostile) == []  # a literal, not query text
    text = load_queries()["mounted_below"].bind(R + "robot", {"link": hostile})
    assert '"x\\" } UNION' in text


def test_numeric_parameters_are_bounded_in_digits_and_exponent(store):
    """`threshold=1e999999999` would be written into the query as a billion digits: refused, as is any number
    whose plain decimal form needs more than 40 digits either side of the point, or written in over 100 characters."""
    for raw in ("1e999999999", "0e-999999999", "1e-41", "1e40", "-1" + "0" * 40):
        with pytest.raises(ParamError, match="at most 40 digits before and 40 after"):
            rows(store, "low_confidence", threshold=raw)
    with pytest.raises(ParamError, match="at most 100 characters"):
        rows(store, "low_confidence", threshold="0." + "1" * 99)
    (threshold,) = load_queries()["low_confidence"].params
    assert threshold.term("1E+2").n3() == '"100"^^<http://www.w3.org/2001/XMLSchema#decimal>'  # plain xsd:decimal
    assert threshold.term("1e-40").n3().startswith('"0.' + "0" * 39 + '1"')
    assert len(rows(store, "low_confidence", threshold="31e-2")) == 2
    app, jobs = make_app(store)
    status, _, out = client(app)("GET", "/queries/low_confidence?robot=pr2&threshold=1e999999999")
    assert status == 400 and "at most 40 digits" in json.loads(out)["error"]
    jobs.shutdown()


def test_a_hostile_parameter_value_is_one_literal_that_round_trips(tmp_path):
    """A link name full of SPARQL syntax is matched exactly, as a value: it neither breaks nor widens the query."""
    from urdfkb.pipeline.abstraction.components import Abstraction, Component, SubComponent
    from urdfkb.pipeline.reading.tree import Edge, KinematicTree, Origin
    odd = 'deck" } UNION { ?component ?p ?o } # \\ \'\'\' """ \n $robot'
    zero = Origin((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    tree = KinematicTree("odd", ("base", odd, "lidar"), (Edge("j1", "fixed", "base", odd, zero),
                                                         Edge("j2", "fixed", odd, "lidar", zero)))
    lidar = Component("lidar", "sensor", "Lidar", 0.9, odd, (SubComponent("lidar", "SensingElement", 0.9),))
    kb = Store(tmp_path / "kb.sqlite3", workers=0)
    try:
        kb.replace_robot("odd", tree, Abstraction((lidar,)))
        found = rows(kb, "mounted_below", "odd", link=odd)
        assert [(r["mount"], r["class"].removeprefix(C)) for r in found] == [(odd, "Lidar")]
        assert rows(kb, "mounted_below", "odd", link=odd[:4]) == []  # no partial match, no injected UNION
    finally:
        kb.close()


def test_http_route_and_cli(store):
    app, jobs = make_app(store)
    api = client(app)
    q = urllib.parse.urlencode({"robot": "pr2", "link": "head_mount_link"})
    status, ctype, out = api("GET", f"/queries/mounted_below?{q}")
    assert status == 200 and ctype.startswith("application/sparql-results+json")
    assert len(json.loads(out)["results"]["bindings"]) == 2
    status, ctype, _ = api("GET", "/queries/sensors?robot=pr2", headers={"Accept": "text/csv"})
    assert status == 200 and ctype.startswith("text/csv")
    status, ctype, out = api("GET", "/queries/low_confidence?robot=pr2&threshold=abc")
    assert status == 400 and "decimal" in json.loads(out)["error"]
    assert api("GET", "/queries/cameras")[0] == 400
    jobs.shutdown()


def test_cli_query(pr2_kb, tmp_path):
    path = copied(pr2_kb, tmp_path)
    out = run_named_query("end_effectors", "pr2", {}, store_path=path, fmt="tsv")
    assert out.splitlines()[0] == "?endEffector\t?class\t?mount\t?tcp\t?contacts"
    assert '"r_gripper_tool_frame"' in out
    table = run_named_query("mounted_below", "pr2", {"link": "head_mount_link"}, store_path=path).splitlines()
    assert table[0].split() == ["component", "class", "mount"] and table[-1] == "(2 rows)"
    assert table[2].split() == ["comp_kinect", "RGBDCamera", "head_mount_link"]
    assert json.loads(run_named_query("cameras", "pr2", {}, store_path=path, fmt="json"))["head"]["vars"] == ["link", "camera", "class"]
    with pytest.raises(UnknownRobot, match="nao"):
        run_named_query("cameras", "nao", {}, store_path=path)
