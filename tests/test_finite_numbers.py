"""Numbers that overflow never reach the store: PR2 with joint limits of ±1e308 or origins of 1e300 (finite in
the XML) is stored with finite numbers, each one that has no plain decimal form left out with a record; the
shapes refuse a decimal that is not finite, also from SPARQL Update; the robot's page answers."""
from __future__ import annotations

import json
import math
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
import rdflib
from rdflib.namespace import XSD

from tests.kb_fixtures import PR2_WHOLE, client, fake_runner, make_app
from tests.test_capabilities import planar_arm
from urdfkb.kb_server.queries import run_named
from urdfkb.kb_server.store import Store
from urdfkb.pipeline.abstraction import capabilities
from urdfkb.pipeline.knowledge import rdf
from urdfkb.pipeline.errors import ShapeError, URDFError
from urdfkb.pipeline.knowledge.export import robot_graph
from urdfkb.pipeline.reading.ingest import load_urdf
from urdfkb.pipeline.knowledge.namespaces import CORE, robot_iri
from urdfkb.pipeline.knowledge.population import build_robot
from urdfkb.pipeline.knowledge.screen import screen
from urdfkb.pipeline.knowledge.shacl import violations
from urdfkb.pipeline.reading.tree import Edge, KinematicTree, Origin

PLAIN_DECIMAL = re.compile(r"[+-]?([0-9]+(\.[0-9]*)?|\.[0-9]+)")
HTML = {"Accept": "text/html"}


def extreme_pr2(shared: Path, limits: bool = True, origins: bool = False) -> bytes:
    """PR2's URDF with every joint limit at ±1e308 and/or every joint origin at (1e300, 1e300, 1e300)."""
    root = ET.parse(shared / "urdf" / "pr2.urdf").getroot()
    for joint in root.iter("joint"):
        limit, origin = joint.find("limit"), joint.find("origin")
        if limits and limit is not None and limit.get("lower") is not None:
            limit.set("lower", "-1e308")
            limit.set("upper", "1e308")
        if origins and origin is not None:
            origin.set("xyz", "1e300 1e300 1e300")
    return ET.tostring(root)


def test_a_revolute_joint_turning_more_than_a_turn_reaches_as_a_continuous_one():
    huge = capabilities.reach(planar_arm((-1e308, 1e308)), "shoulder", "hand")
    assert huge == pytest.approx(0.5)  # the elbow straightens, as it does within (-2, 0.5)
    slide = KinematicTree("slide", ("base", "carriage"), (
        Edge("rail", "prismatic", "base", "carriage", Origin((0.0, 0.0, 0.0), (0.0, 0.0, 0.0)), (1.0, 0.0, 0.0),
             (-1e308, 1e308)),))
    far = capabilities.reach(slide, "rail", "carriage")
    assert far is not None and not math.isfinite(far)  # population's to leave out


def test_a_number_that_is_not_finite_in_the_urdf_is_refused_naming_the_joint_and_attribute(shared):
    urdf = extreme_pr2(shared).replace(b'upper="1e308"', b'upper="1e400"', 1)
    with pytest.raises(URDFError, match=r"<limit> attribute upper='1e400' is not a number \(at joint '"):
        load_urdf(urdf)


def test_the_screen_gives_the_trace_a_record_of_each_number_left_out(shared):
    records: list[dict] = []
    screen(load_urdf(extreme_pr2(shared)), PR2_WHOLE, records.append)
    assert {"key": "left_out", "robot": "pr2", "subject": "body_head", "property": "panRangeRadians", "value": "inf",
            "why": "not a finite number"} in records


@pytest.mark.parametrize("limits, origins", [(True, False), (True, True)])
def test_population_leaves_out_each_number_without_a_plain_decimal_form_and_records_it(shared, limits, origins):
    tree = load_urdf(extreme_pr2(shared, limits, origins))
    records: list[dict] = []
    world = rdf.new_world()
    onto = build_robot(world, tree, "pr2", PR2_WHOLE, record=records.append)
    graph = robot_graph(onto)
    decimals = [o for o in graph.objects() if isinstance(o, rdflib.Literal) and o.datatype == XSD.decimal]
    assert decimals and all(PLAIN_DECIMAL.fullmatch(str(o)) for o in decimals)
    assert all(PLAIN_DECIMAL.fullmatch(line.split('"')[1]) for line in rdf.ntriples(onto).decode().splitlines()
               if "XMLSchema#decimal" in line)  # as the SPARQL index loads it, not only as rdflib reads it
    assert violations(graph) == []
    left = {(r["subject"], r["property"]) for r in records}
    assert all(r["key"] == "left_out" and r["robot"] == "pr2" and r["why"] for r in records)
    if limits:
        assert {("joint_r_elbow_flex_joint", "lowerLimit"), ("joint_torso_lift_joint", "upperLimit")} <= left
    if origins:
        assert ("body_r_arm", "reachMetres") in left
    if limits and not origins:  # PR2's arms and fingers turn: their joint space is the full turn, and finite
        assert ("body_head", "panRangeRadians") in left  # upper minus lower overflows
        reach = graph.value(rdflib.URIRef(robot_iri("pr2") + "body_r_arm"), CORE.reachMetres)
        assert isinstance(reach, rdflib.Literal) and 0.5 < float(reach) < 2
        assert ("comp_r_gripper", "maxOpeningMetres") not in left
    world.close()


def test_the_shapes_refuse_decimals_that_are_not_finite():
    g = rdflib.Graph()
    robot = rdflib.Namespace(robot_iri("x"))
    bad = ["INF", "-INF", "NaN", "None", "1e+308", "12345678901234567"]
    for i, text in enumerate(["0.5", "-12.25", "3", *bad]):
        g.add((robot[f"body_{i}"], CORE.reachMetres, rdflib.Literal(text, datatype=XSD.decimal)))
    g.add((robot["body_d"], CORE.reachMetres, rdflib.Literal(0.5)))  # an xsd:double
    g.add((robot["comp_nan"], CORE.confidence, rdflib.Literal("NaN", datatype=XSD.decimal)))  # never raises
    g.add((robot["comp_one"], CORE.confidence, rdflib.Literal("1.0", datatype=XSD.decimal)))
    found = violations(g)
    assert {line.split(":")[1].split()[0] for line in found} == {
        *(f"body_{i}" for i in range(3, 3 + len(bad))), "body_d", "comp_nan"}
    assert "DecimalShape: body_3 reachMetres: not a finite xsd:decimal under 1e16" in found


@pytest.fixture
def api(tmp_path):
    store = Store(tmp_path / "kb.sqlite3", workers=0)
    app, jobs = make_app(store, runner=fake_runner({"pr2": PR2_WHOLE}))
    yield client(app), store
    jobs.shutdown()
    store.close()


@pytest.mark.slow  # over a second of its own (make test-fast leaves it out)
def test_a_robot_whose_numbers_overflow_is_stored_finite_and_its_page_answers(api, shared):
    call, store = api
    status, _, out = call("POST", "/populate", extreme_pr2(shared, origins=True), {"Content-Type": "application/xml"})
    assert status == 202
    status, _, out = call("GET", f"/jobs/{json.loads(out)['id']}?wait=1&timeout=60")
    assert json.loads(out)["state"] == "succeeded", out
    status, ctype, page = call("GET", "/robots/pr2", None, HTML)
    assert status == 200 and ctype.startswith("text/html") and b"r_arm" in page
    assert call("GET", "/robots/pr2")[0] == 200
    rows = run_named(store, "arm_reach", "pr2", {}).as_dicts()
    assert rows and all("reach" not in r for r in rows)  # left out, not "None" or "INF"
    with pytest.raises(ShapeError, match="DecimalShape: body_r_arm reachMetres"):
        store.update(f'INSERT DATA {{ GRAPH <{robot_iri("pr2")}> {{ <{robot_iri("pr2")}body_r_arm> '
                     f'<{CORE.reachMetres}> "INF"^^<{XSD.decimal}> }} }}')
