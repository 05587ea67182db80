"""The whole body on the review page and its corrections (reclassify, side, merge, split, reject; kept across
re-populates; refused with a clear message when they do not fit): PR2 with its hand-written body
(kb_fixtures.PR2_WHOLE, no model)."""
from __future__ import annotations

import json
import re
from dataclasses import replace
from html.parser import HTMLParser

import pytest
import rdflib
from rdflib.namespace import RDF

from tests.kb_fixtures import PR2_ARM, PR2_WHOLE, client, copied, make_app
from urdfkb.kb_server import palette
from urdfkb.kb_server.corrections import PROV, REVIEW, CorrectionError, new
from urdfkb.kb_server.queries import run_named
from urdfkb.kb_server.store import Store
from urdfkb.pipeline.abstraction.components import Abstraction
from urdfkb.pipeline.knowledge.namespaces import robot_iri

HTML = {"Accept": "text/html,application/xhtml+xml,application/xml;q=0.9,*/*;q=0.8"}


@pytest.fixture
def store(whole_pr2_kb, tmp_path):
    """This test's own store holding PR2 with its whole body (a copy of conftest's whole_pr2_kb)."""
    s = Store(copied(whole_pr2_kb, tmp_path), workers=0)
    yield s
    s.close()


@pytest.fixture
def api(store):
    app, jobs = make_app(store)
    yield client(app)
    jobs.shutdown()


class Page(HTMLParser):
    """The body table's rows (cells' text) and the SVG's body-part bands (their links' count)."""

    def __init__(self, html: str):
        super().__init__()
        self.rows: dict[str, list[str]] = {}
        self.bands: dict[str, int] = {}
        self._row: list[str] | None = None
        self._band: str | None = None
        self.feed(html)

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag == "tr" and "body-row" in a.get("class", ""):
            self._row = self.rows.setdefault(a["data-part"], [])
        elif tag == "td" and self._row is not None:
            self._row.append("")
        elif tag == "g" and a.get("class") == "body-part":
            self._band = a["data-part"]
            self.bands[self._band] = 0
        elif tag == "rect" and self._band:
            self.bands[self._band] += 1

    def handle_endtag(self, tag):
        if tag == "tr":
            self._row = None
        elif tag == "g":
            self._band = None

    def handle_data(self, data):
        if self._row:
            self._row[-1] += " " + data.strip() if data.strip() else ""


def words(cell: str) -> list[str]:
    return cell.split()


def test_the_page_lists_and_draws_every_body_part(api):
    status, _, html = api("GET", "/robots/pr2", headers=HTML)
    page = Page(html.decode())
    assert set(page.rows) == {p.name for p in PR2_WHOLE.body}
    part, side, joints, on, _ = page.rows["l_arm"]
    assert words(part) == ["Arm", "l_arm", "hangs", "from", "torso_lift_link", "reaches", "1.00", "m", "·", "7", "degrees",
                           "of", "freedom"] and side.strip() == "left"
    assert words(joints) == [f"l_{j}_joint" for j in PR2_ARM]  # root-most first
    assert words(on) == ["l_gripper", "ParallelGripper"]
    part, side, joints, on, _ = page.rows["head"]
    assert side.strip() == "" and words(joints) == ["head_pan_joint", "head_tilt_joint"]
    assert set(words(on)) == {"kinect", "RGBDCamera", "wide_stereo", "StereoCamera", "prosilica", "MonocularCamera"}
    assert "part of base" in page.rows["fl_caster_l_wheel"][0]
    # one band per part, a box under each of its links
    assert page.bands == {f"body_{p.name}": len(p.links) for p in PR2_WHOLE.body}
    arm = palette.body_swatch("Arm").colour
    assert len(re.findall(rf'class="joint"[^>]*style="stroke: {arm}', html.decode())) == 14  # both arms' joints
    assert html.decode().count('<text class="side"') == sum(len(p.links) for p in PR2_WHOLE.body if p.side)


# --- body corrections ---------------------------------------------------------------------------

def correct(store, **data):
    return store.add_correction("pr2", new({"reviewer": "ann", **data}))


def body(store, robot="pr2") -> dict[str, dict]:
    """The stored body parts (body_parts query): class, side, mount, confidence, joints root-most first."""
    parts: dict[str, dict] = {}
    for r in run_named(store, "body_parts", robot, {}).as_dicts():
        part = parts.setdefault(r["name"], {"class": r["class"].rsplit("#", 1)[1], "side": r.get("side"), "mount": r.get("mount"),
                                            "confidence": float(r["confidence"]), "parent": r.get("parent"), "joints": []})
        if "joint" in r:
            part["joints"].append(r["joint"])
    return parts


def located(store, robot="pr2") -> dict[str, tuple[str, str | None]]:
    """Each located component's body part and side, as stored."""
    rows = store.query(f"PREFIX core: <https://w3id.org/urdfkb/core#> PREFIX rdfs: <http://www.w3.org/2000/01/rdf-schema#> "
                       f"SELECT ?c ?p ?side WHERE {{ GRAPH <{robot_iri(robot)}> {{ ?comp core:isLocatedOn ?part ; rdfs:label ?c . "
                       f"?part rdfs:label ?p . OPTIONAL {{ ?comp core:side ?side }} }} }}").as_dicts()
    return {r["c"]: (r["p"], r.get("side")) for r in rows}


@pytest.mark.slow  # over a second of its own (make test-fast leaves it out)
def test_reclassify_and_side(store):
    correct(store, part="torso", action="reclassify", **{"class": "Leg"})
    entry = correct(store, part="head", action="side", side="left")
    parts = body(store)
    assert parts["torso"]["class"] == "Leg" and parts["torso"]["confidence"] == 1.0
    assert parts["head"]["side"] == "left" and located(store)["kinect"] == ("head", "left")  # what is on it takes its side
    assert [a["part"] for a in entry.corrections["applied"]] == ["torso", "head"]
    correct(store, part="head", action="side", side="none")
    assert body(store)["head"]["side"] is None and located(store)["kinect"] == ("head", None)


@pytest.mark.slow  # over a second of its own (make test-fast leaves it out)
def test_split_an_arm_at_its_elbow_and_merge_the_head_into_the_torso(store):
    correct(store, part="l_arm", action="split", at="l_elbow_flex_joint")
    correct(store, part="head", action="merge", **{"with": "torso"})
    parts = body(store)
    assert parts["l_arm"]["joints"] == [f"l_{j}_joint" for j in PR2_ARM[:3]]
    assert parts["arm_l_elbow_flex_joint"] == {"class": "Arm", "side": "left", "mount": "l_upper_arm_link",
                                               "confidence": 1.0, "parent": None,
                                               "joints": [f"l_{j}_joint" for j in PR2_ARM[3:]]}
    assert located(store)["l_gripper"] == ("arm_l_elbow_flex_joint", "left")  # its mount moved with the forearm
    assert "head" not in parts and parts["torso"]["joints"] == ["torso_lift_joint", "head_pan_joint", "head_tilt_joint"]
    assert parts["torso"]["mount"] == "base_link" and located(store)["kinect"] == ("torso", None)


@pytest.mark.slow  # over a second of its own (make test-fast leaves it out)
def test_reject_moves_what_was_on_a_part_to_the_part_above(store):
    correct(store, part="head", action="reject")
    correct(store, part="base", action="reject")
    parts = body(store)
    assert "head" not in parts and "base" not in parts
    assert located(store)["kinect"] == ("torso", None)  # its mount hangs from the torso's links
    assert "base_laser" not in located(store)  # base_link is in no part now
    assert parts["fl_caster_l_wheel"]["parent"] is None  # the robot's own part now


@pytest.mark.slow  # over a second of its own (make test-fast leaves it out)
def test_body_corrections_survive_repopulation_and_find_their_parts_by_joints(store, pr2_tree):
    correct(store, part="l_arm", action="split", at="l_elbow_flex_joint")
    correct(store, part="arm_l_elbow_flex_joint", action="reclassify", **{"class": "Leg"})
    correct(store, part="head", action="side", side="right")
    before = body(store)
    entry = store.replace_robot("pr2", pr2_tree, PR2_WHOLE)
    assert [a["summary"] for a in entry.corrections["applied"]] == [
        "body part l_arm: split at l_elbow_flex_joint", "body part arm_l_elbow_flex_joint: class -> Leg",
        "body part head: side -> right"] and entry.corrections["stale"] == []
    assert body(store) == before
    # the model names its parts otherwise next time: the joints still find them
    renamed = replace(PR2_WHOLE, body=tuple(replace(p, name=f"part_{p.name}", parent=p.parent and f"part_{p.parent}")
                                            for p in PR2_WHOLE.body),
                      components=tuple(replace(c, located_on=f"part_{c.located_on}") for c in PR2_WHOLE.components))
    store.replace_robot("pr2", pr2_tree, renamed)
    parts = body(store)
    assert parts["arm_l_elbow_flex_joint"]["class"] == "Leg" and parts["part_head"]["side"] == "right"
    assert parts["part_l_arm"]["joints"] == [f"l_{j}_joint" for j in PR2_ARM[:3]]
    # a URDF without the head's tilt joint: that correction no longer fits, the others still apply
    gone = {"head_tilt_link", *pr2_tree.descendants("head_tilt_link")}
    smaller = replace(pr2_tree, links=tuple(link for link in pr2_tree.links if link not in gone),
                      edges=tuple(e for e in pr2_tree.edges if e.child not in gone))
    head = replace(PR2_WHOLE.body[10], joints=("head_pan_joint",), links=("head_pan_link",))
    entry = store.replace_robot("pr2", smaller, Abstraction((), {}, (*PR2_WHOLE.body[:10], head, *PR2_WHOLE.body[11:])))
    (stale,) = entry.corrections["stale"]
    assert stale["summary"] == "body part head: side -> right" and "head_tilt_joint is not in the URDF" in stale["reason"]
    assert len(entry.corrections["applied"]) == 2 and len(store.corrections("pr2")) == 3


MALFORMED: list[tuple[dict[str, object], str]] = [  # refused before the robot is looked at
    ({"part": "head", "action": "reclassify", "class": "Camera"}, "'Camera' is not a body-part class of the ontology"),
    ({"part": "head", "action": "reclassify", "class": "Tentacle"}, "'Tentacle' is not a body-part class"),
    ({"part": "head", "action": "reclassify", "class": "BodyPart"}, "'BodyPart' is not a body-part class"),
    ({"part": "l_arm", "action": "split", "at": "l_elbow_flex_joint", "class": "Gripper"}, "'Gripper' is not a body-part"),
    ({"part": "head", "action": "side", "side": "port"}, "side must be one of left, right, none, not 'port'"),
    ({"part": "head", "action": "side"}, "side needs `side`"),
    ({"part": "head", "action": "wiggle"}, "a body part's action must be one of"),
    ({"part": "", "action": "reject"}, "part must name the body part"),
    ({"part": ["head"], "action": "reject"}, "part must be a string"),
]
MISFIT: list[tuple[dict[str, object], str]] = [  # refused by the robot as it is
    ({"part": "tail", "action": "side", "side": "left"}, "no body part 'tail' on this robot (its parts: base, "),
    ({"part": "l_arm", "action": "merge", "with": "r_arm"}, "l_arm and r_arm do not touch"),
    ({"part": "l_arm", "action": "merge", "with": "l_arm"}, "cannot be merged with itself"),
    ({"part": "l_arm", "action": "merge", "with": "nose"}, "no body part 'nose'"),
    ({"part": "l_arm", "action": "split", "at": "l_shoulder_pan_joint"}, "leaves nothing above it"),
    ({"part": "l_arm", "action": "split", "at": "head_pan_joint"}, "head_pan_joint is not a joint of l_arm"),
]


@pytest.mark.parametrize("data, message", MALFORMED)
def test_malformed_body_corrections_are_refused(data, message):
    with pytest.raises(CorrectionError, match=re.escape(message)):
        new(data)


def test_body_corrections_that_do_not_fit_are_refused_with_a_400_and_change_nothing(store, api):
    before = store.export("pr2", "nt")
    for data, message in MISFIT:
        with pytest.raises(CorrectionError, match=re.escape(message)):
            store.add_correction("pr2", new(data))
    for data, message in [*MALFORMED, *MISFIT]:
        status, _, out = api("POST", "/robots/pr2/corrections", json.dumps(data).encode(), {"Content-Type": "application/json"})
        assert status == 400 and message in json.loads(out)["error"]
    assert store.export("pr2", "nt") == before and store.corrections("pr2") == []


@pytest.mark.slow  # over a second of its own (make test-fast leaves it out)
def test_over_http_with_provenance(store, api):
    json_type = {"Content-Type": "application/json"}
    status, _, out = api("POST", "/robots/pr2/corrections", json.dumps(
        {"part": "head", "action": "side", "side": "left", "reviewer": "Bo"}).encode(), json_type)
    stored = json.loads(out)["correction"]
    assert status == 201 and stored["joints"] == ["head_pan_joint", "head_tilt_joint"] and stored["part"] == "head"
    status, _, out = api("GET", "/robots/pr2/corrections")
    assert [a["summary"] for a in json.loads(out)["applied"]] == ["body part head: side -> left"]
    graph = rdflib.Graph().parse(data=store.export("pr2", "ttl"), format="turtle")
    (activity,) = graph.subjects(RDF.type, REVIEW.BodyPartCorrection)
    assert (rdflib.URIRef("https://w3id.org/urdfkb/robot/pr2#body_head"), PROV.wasInfluencedBy, activity) in graph
    assert {str(j) for j in graph.objects(activity, REVIEW.joint)} == {"head_pan_joint", "head_tilt_joint"}
    _, _, html = api("GET", "/robots/pr2", headers=HTML)
    assert "corrected by Bo" in Page(html.decode()).rows["head"][0]


def test_an_added_component_leaves_the_body_part_and_is_located_on_it(store):
    store.add_correction("pr2", new({"action": "add", "links": ["head_plate_frame"], "class": "MonocularCamera"}))
    assert located(store)["reviewed_head_plate_frame"] == ("head", None)
    links = store.query("PREFIX core: <https://w3id.org/urdfkb/core#> SELECT ?n WHERE { "
                        "<https://w3id.org/urdfkb/robot/pr2#body_head> core:hasLink/core:urdfName ?n }").as_dicts()
    assert "head_plate_frame" not in {r["n"] for r in links} and len(links) == 5
