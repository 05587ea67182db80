"""Reviewers' corrections: each action, their provenance in exports, re-application on re-populate,
corrections that no longer fit, the token, the low_confidence query, the pages' negotiation."""
from __future__ import annotations

import json
from dataclasses import replace

import pytest
import rdflib

from tests.kb_fixtures import PR2, client, copied, make_app
from urdfkb.kb_server import queries
from urdfkb.kb_server.corrections import PROV, REVIEW, Correction, CorrectionError, corrections_iri
from urdfkb.kb_server.store import Store, UnknownRobot
from urdfkb.pipeline.abstraction.components import Abstraction
from urdfkb.pipeline.errors import ShapeError
from urdfkb.pipeline.knowledge.shacl import violations
from urdfkb.settings import REVIEW_THRESHOLD

TOKEN = "s3cret"


@pytest.fixture
def store(pr2_store):
    """This test's own store holding PR2 (conftest)."""
    return pr2_store


def correct(store, who="ann", **data):
    return store.add_correction("pr2", Correction.new(data, who))


def components(store):
    return {c["iri"].rsplit("#comp_", 1)[1]: c for c in queries.components(store, "pr2")}


@pytest.mark.slow  # over a second of its own (make test-fast leaves it out)
def test_each_action_changes_the_stored_robot(store):
    correct(store, action="reclassify", links=["head_mount_prosilica_optical_frame"], **{"class": "StereoCamera"})
    correct(store, action="remount", links=["base_laser_link"], mount="base_footprint")
    correct(store, action="reject", links=["r_gripper_motor_accelerometer_link"])
    entry = correct(store, action="add", links=["l_forearm_cam_optical_frame", "l_forearm_cam_frame"],
                    **{"class": "MonocularCamera"})
    comps = components(store)
    assert comps["prosilica"]["class"] == "StereoCamera" and comps["prosilica"]["confidence"] == 1.0
    assert comps["base_laser"]["mount"] == "base_footprint"
    assert "r_gripper_accelerometer" not in comps
    added = comps["reviewed_l_forearm_cam_frame"]
    assert added["class"] == "MonocularCamera" and added["mount"] == "l_forearm_roll_link"
    assert {(s["link"], s["class"]) for s in added["subcomponents"]} == {  # the camera's optical frame, as the shapes want
        ("l_forearm_cam_optical_frame", "OpticalFrame"), ("l_forearm_cam_frame", "Subpart")}
    assert len(entry.corrections["applied"]) == 4 and entry.corrections["stale"] == []


@pytest.mark.parametrize("data, message", [
    ({"action": "reclassify", "links": ["base_laser_link"], "class": "ParallelGripper"}, "not a class the ontology allows"),
    ({"action": "reclassify", "links": ["head_mount_kinect_ir_link", "head_mount_kinect_rgb_optical_frame",
                                        "head_mount_kinect_ir_optical_frame"], "class": "Lidar"}, "not a class the ontology allows"),
    ({"action": "remount", "links": ["base_laser_link"], "mount": "r_gripper_palm_link"}, "not above every link"),
    ({"action": "confirm", "links": ["torso_lift_link"]}, "no component with link"),
    ({"action": "confirm", "links": ["no_such_link"]}, "not in the URDF"),
    ({"action": "add", "links": ["base_link"], "class": "Palm"}, "not a sensor or end-effector class"),
    ({"action": "explode", "links": ["base_link"]}, "action must be one of"),
])
def test_corrections_that_do_not_fit_are_refused_and_change_nothing(store, data, message):
    before = store.export("pr2", "nt")
    with pytest.raises(CorrectionError, match=message):
        store.add_correction("pr2", Correction.new(data, "ann"))
    assert store.export("pr2", "nt") == before and store.corrections("pr2") == []


@pytest.mark.slow  # over a second of its own (make test-fast leaves it out)
def test_a_correction_that_breaks_the_shapes_is_refused_and_changes_nothing(store):
    correct(store, action="add", links=["l_forearm_cam_frame"], **{"class": "VisionSensor"})  # no frame required
    before, stored = store.export("pr2", "nt"), store.corrections("pr2")
    with pytest.raises(CorrectionError, match="CameraShape: comp_reviewed_l_forearm_cam_frame hasComponent: "
                                              "a camera needs at least one OpticalFrame"):
        correct(store, action="reclassify", links=["l_forearm_cam_frame"], **{"class": "MonocularCamera"})
    assert store.export("pr2", "nt") == before and store.corrections("pr2") == stored
    assert components(store)["reviewed_l_forearm_cam_frame"]["class"] == "VisionSensor"


def test_a_populate_that_breaks_the_shapes_is_refused_and_the_stored_robot_stays(store, pr2_tree):
    """Every stored robot passes the shapes: a populate whose answer breaks them (a camera with no optical
    frame) is refused as the command line refuses to write it, and the robot stored before is kept."""
    before = store.export("pr2", "nt")
    camera = next(c for c in PR2.components if c.cls.endswith("Camera"))
    broken = replace(camera, subcomponents=tuple(replace(s, cls="SensorHousing") for s in camera.subcomponents))
    bad = Abstraction(tuple(broken if c is camera else c for c in PR2.components), PR2.provenance, PR2.body)
    with pytest.raises(ShapeError, match="breaks the SHACL shapes, so it was not stored: CameraShape"):
        store.replace_robot("pr2", pr2_tree, bad)
    assert store.export("pr2", "nt") == before


@pytest.mark.slow  # over a second of its own (make test-fast leaves it out)
def test_a_correction_the_shapes_accept_is_stored_and_the_robot_conforms(store):
    correct(store, action="add", links=["l_forearm_cam_frame", "l_forearm_cam_optical_frame"], **{"class": "Camera"})
    correct(store, action="reclassify", links=["l_forearm_cam_frame", "l_forearm_cam_optical_frame"],
            **{"class": "MonocularCamera"})
    assert components(store)["reviewed_l_forearm_cam_frame"]["class"] == "MonocularCamera"
    graph = rdflib.Graph().parse(data=store.export("pr2", "nt"), format="nt")
    assert violations(graph) == [] and len(store.corrections("pr2")) == 2


@pytest.mark.slow  # over a second of its own (make test-fast leaves it out)
def test_corrections_carry_provenance_into_exports(store):
    correct(store, who="Ann Reviewer", action="confirm", links=["base_laser_link"])
    graph = rdflib.Graph().parse(data=store.export("pr2", "ttl"), format="turtle")
    (activity,) = graph.subjects(REVIEW.action, rdflib.Literal("confirm"))
    assert (activity, rdflib.RDF.type, PROV.Activity) in graph
    agent = graph.value(activity, PROV.wasAssociatedWith)
    assert str(graph.value(agent, rdflib.RDFS.label)) == "Ann Reviewer"
    ended = graph.value(activity, PROV.endedAtTime)
    assert isinstance(ended, rdflib.Literal) and ended.datatype == rdflib.XSD.dateTime
    assert str(activity).startswith(corrections_iri("pr2"))
    assert (rdflib.URIRef("https://w3id.org/urdfkb/robot/pr2#comp_base_laser"), PROV.wasInfluencedBy, activity) in graph


@pytest.mark.slow  # over a second of its own (make test-fast leaves it out)
def test_corrections_survive_repopulation_and_report_what_no_longer_fits(store, pr2_tree):
    correct(store, action="reclassify", links=["head_mount_prosilica_optical_frame"], **{"class": "StereoCamera"})
    correct(store, action="reject", links=["laser_tilt_link"])
    entry = store.replace_robot("pr2", pr2_tree, PR2)
    assert [a["component"] for a in entry.corrections["applied"]] == ["prosilica", "tilt_laser"]
    assert components(store)["prosilica"]["class"] == "StereoCamera" and "tilt_laser" not in components(store)
    # a new URDF without the tilting laser: that correction no longer fits, the other still applies
    smaller = replace(pr2_tree, links=tuple(link for link in pr2_tree.links if link != "laser_tilt_link"),
                      edges=tuple(e for e in pr2_tree.edges if e.child != "laser_tilt_link"))
    model = Abstraction(tuple(c for c in PR2.components if c.name != "tilt_laser"), PR2.provenance)
    entry = store.replace_robot("pr2", smaller, model)
    assert [a["component"] for a in entry.corrections["applied"]] == ["prosilica"]
    (stale,) = entry.corrections["stale"]
    assert stale["action"] == "reject" and "laser_tilt_link is not in the URDF" in stale["reason"]
    assert len(store.corrections("pr2")) == 2  # kept: it applies again if the link comes back


def test_low_confidence_skips_confirmed_components_and_their_parts(store):
    def low():
        return {d["individual"].rsplit("#", 1)[1] for d in queries.run_named(store, "low_confidence", "pr2", {}).as_dicts()}
    assert {"comp_r_gripper_accelerometer", "comp_prosilica"} <= low()
    correct(store, action="confirm", links=["r_gripper_motor_accelerometer_link"])
    assert not {i for i in low() if "accelerometer" in i}
    assert "comp_prosilica" in low()


def test_the_pages_get_the_review_threshold_the_low_confidence_query_serves(store):
    app, jobs = make_app(store)
    try:
        api = client(app)
        (query,) = [q for q in json.loads(api("GET", "/queries")[2]) if q["name"] == "low_confidence"]
        (threshold,) = [p["default"] for p in query["params"] if p["name"] == "threshold"]
        with app.test_request_context("/"):
            context: dict = {}
            app.update_template_context(context)
        assert float(threshold) == context["review_threshold"] == REVIEW_THRESHOLD
        page = api("GET", "/robots/pr2", headers={"Accept": "text/html"})[2]
        assert f"confidence below {threshold}".encode() in page
    finally:
        jobs.shutdown()


@pytest.mark.slow  # over a second of its own (make test-fast leaves it out)
def test_deleting_a_robot_removes_its_corrections(store, pr2_tree):
    correct(store, action="confirm", links=["base_laser_link"])
    store.delete_robot("pr2")
    assert store.corrections("pr2") == []
    with pytest.raises(UnknownRobot):
        store.source("pr2")
    store.replace_robot("pr2", pr2_tree, PR2)
    assert store.corrections("pr2") == []


@pytest.mark.slow  # over a second of its own (make test-fast leaves it out)
def test_http_corrections_need_the_token_and_pages_are_negotiated(tmp_path, shared):
    store = Store(tmp_path / "kb.sqlite3", workers=0)
    app, jobs = make_app(store, token=TOKEN)
    auth = {"Authorization": f"Bearer {TOKEN}"}
    try:
        api = client(app)
        status, _, out = api("POST", "/populate", (shared / "urdf" / "pr2.urdf").read_bytes(), auth)
        api("GET", f"/jobs/{json.loads(out)['id']}?wait=1")
        body = json.dumps({"action": "confirm", "links": ["base_laser_link"], "reviewer": "Ann"}).encode()
        json_type = {"Content-Type": "application/json"}
        assert api("POST", "/robots/pr2/corrections", body, json_type)[0] == 403
        status, _, out = api("POST", "/robots/pr2/corrections", body, {**json_type, **auth})
        assert status == 201 and json.loads(out)["correction"]["reviewer"] == "Ann"
        status, _, out = api("POST", "/robots/pr2/corrections", b"[1]", {**json_type, **auth})
        assert status == 400
        for data, status in (({"action": "add", "links": ["l_forearm_cam_frame"], "class": "VisionSensor"}, 201),
                             ({"action": "reclassify", "links": ["l_forearm_cam_frame"], "class": "Camera"}, 400)):
            got, _, out = api("POST", "/robots/pr2/corrections", json.dumps(data).encode(), {**json_type, **auth})
            assert got == status
        assert "breaks the SHACL shapes" in json.loads(out)["error"] and "CameraShape" in json.loads(out)["error"]
        status, _, out = api("POST", "/robots/ghost/corrections", body, {**json_type, **auth})
        assert status == 404
        status, _, out = api("GET", "/robots/pr2/corrections")
        assert status == 200 and json.loads(out)["applied"][0]["summary"] == "base_laser_link: confirmed"
        assert len(json.loads(out)["applied"]) == 2  # the refused one is not stored

        browser = {"Accept": "text/html,application/xhtml+xml,application/xml;q=0.9,*/*;q=0.8"}
        status, ctype, page = api("GET", "/robots/pr2", headers=browser)
        assert status == 200 and ctype.startswith("text/html")
        assert b"<svg" in page and b"confirmed by Ann" in page and b'data-links="base_laser_link"' in page
        assert api("GET", "/robots/pr2")[1].startswith("application/json")
        assert api("GET", "/robots/pr2", headers={"Accept": "application/json"})[1].startswith("application/json")
        assert api("GET", "/robots/ghost", headers=browser)[0] == 404
        status, ctype, page = api("GET", "/sparql", headers=browser)
        assert status == 200 and ctype.startswith("text/html") and b"low_confidence" in page
        assert api("GET", "/sparql")[1].startswith("text/turtle")  # the service description
        status, ctype, page = api("GET", "/", headers=browser)
        assert status == 200 and b'data-robot="pr2"' in page
    finally:
        jobs.shutdown()
        store.close()


def test_corrections_are_in_the_sparql_index_after_a_restart(tmp_path, pr2_kb):
    path = copied(pr2_kb, tmp_path)
    store = Store(path, workers=0)
    correct(store, action="confirm", links=["head_mount_prosilica_optical_frame"])
    ask = f"ASK {{ GRAPH <{corrections_iri('pr2')}> {{ ?s ?p ?o }} }}"
    assert json.loads(store.query(ask).body)["boolean"]
    store.close()
    store = Store(path, workers=0)
    try:
        assert json.loads(store.query(ask).body)["boolean"]
    finally:
        store.close()


@pytest.mark.slow  # over a second of its own (make test-fast leaves it out)
def test_sparql_update_cannot_rewrite_a_corrections_graph(store):
    from urdfkb.kb_server.store import ReadOnlyGraph
    correct(store, action="confirm", links=["head_mount_prosilica_optical_frame"])
    with pytest.raises(ReadOnlyGraph, match="corrections"):
        store.update(f"INSERT DATA {{ GRAPH <{corrections_iri('pr2')}> {{ <urn:a> <urn:b> <urn:c> }} }}")
    store.update("DROP ALL")  # every writable graph: the robot goes, its corrections stay read-only here
    with pytest.raises(LookupError, match="no robot"):  # ...and no correction brings the dropped robot back
        correct(store, action="confirm", links=["head_mount_prosilica_optical_frame"])
