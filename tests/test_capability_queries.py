"""The queries of what parts can do (camera_frames, arm_reach, gripper_opening) over HTTP on a live server, through
urdfkb.client, by an independent engine, and on the robot's review page: PR2 with its hand-written body
(conftest's whole_pr2_kb), no model."""
from __future__ import annotations

import json
import math
import re
import urllib.parse
from decimal import Decimal
from html.parser import HTMLParser

import pytest

from tests.kb_fixtures import both_engines, http, served
from urdfkb.client import ArmReach, CameraFrame, KnowledgeBase

HTML = {"Accept": "text/html,application/xhtml+xml,application/xml;q=0.9,*/*;q=0.8"}


@pytest.fixture(scope="module")
def url(whole_pr2_store):
    with served(whole_pr2_store) as base:
        yield base


def rows(url: str, name: str, **args) -> list[dict[str, str]]:
    status, ctype, body = http("GET", f"{url}/queries/{name}?{urllib.parse.urlencode({'robot': 'pr2', **args})}")
    assert status == 200 and ctype.startswith("application/sparql-results+json"), body
    return [{k: v["value"].rsplit("#", 1)[-1] for k, v in row.items()} for row in json.loads(body)["results"]["bindings"]]


def test_camera_frames_over_http(url):
    kinect = {r["frame"]: r for r in rows(url, "camera_frames") if r["name"] == "kinect"}
    assert {f: r["modality"] for f, r in kinect.items()} == {
        "head_mount_kinect_rgb_optical_frame": "RgbFrame", "head_mount_kinect_ir_optical_frame": "DepthFrame"}
    rgb = kinect["head_mount_kinect_rgb_optical_frame"]
    assert (rgb["class"], rgb["modalityLabel"], rgb["width"], rgb["height"], rgb["rate"]) == ("RGBDCamera", "RGB frame", "640", "480", "1")
    assert float(rgb["fov"]) == pytest.approx(math.radians(57), abs=1e-4)
    assert sorted(rgb["referenceFrames"].split()) == ["head_mount_kinect_ir_optical_frame", "head_mount_kinect_rgb_optical_frame"]
    cameras = {r["name"] for r in rows(url, "camera_frames")}
    assert cameras == {"kinect", "wide_stereo", "prosilica", "r_forearm_cam"}


def test_arm_reach_and_gripper_opening_over_http(url):
    arms = rows(url, "arm_reach")
    assert [(r["name"], r["side"], r["mount"], r["degreesOfFreedom"]) for r in arms] == [
        ("l_arm", "left", "torso_lift_link", "7"), ("r_arm", "right", "torso_lift_link", "7")]
    assert all(float(r["reach"]) == pytest.approx(1.001, abs=1e-3) for r in arms)  # shoulder pan to tool frame, straight
    assert [r["name"] for r in rows(url, "arm_reach", side="Right")] == ["r_arm"]
    grippers = {r["name"]: r for r in rows(url, "gripper_opening")}
    assert {n: (r["arm"], r["side"], r["classLabel"]) for n, r in grippers.items()} == {
        "l_gripper": ("body_l_arm", "left", "parallel gripper"), "r_gripper": ("body_r_arm", "right", "parallel gripper")}
    assert all(float(r["opening"]) == pytest.approx(0.0938, abs=1e-4) for r in grippers.values())
    status, _, body = http("GET", f"{url}/queries/arm_reach?robot=pr2_no_body")
    assert status == 200 and json.loads(body)["results"]["bindings"] == []


def test_the_queries_are_listed_with_their_parameters(url):
    status, _, body = http("GET", f"{url}/queries")
    listed = {q["name"]: q for q in json.loads(body)}
    assert listed["camera_frames"]["params"] == [] and listed["gripper_opening"]["params"] == []
    assert [(p["name"], p["default"]) for p in listed["arm_reach"]["params"]] == [("side", "any")]


def test_the_client_has_a_method_each(url):
    kb = KnowledgeBase(url)
    frames = {f.frame: f for f in kb.camera_frames("pr2")}
    assert frames["head_mount_kinect_ir_optical_frame"] == CameraFrame(
        "kinect", "RGBDCamera", "head_mount_kinect_ir_optical_frame", "DepthFrame", "depth frame",
        frames["head_mount_kinect_ir_optical_frame"].fov, 640, 480, 1.0,
        ("head_mount_kinect_ir_optical_frame", "head_mount_kinect_rgb_optical_frame"))
    assert frames["r_forearm_cam_optical_frame"].fov == pytest.approx(math.pi / 2, abs=1e-4)
    assert frames["wide_stereo_l_stereo_camera_optical_frame"].fov is None  # its declarations name other links
    [left] = kb.arm_reach("pr2", side="left")
    assert left == ArmReach("l_arm", "left", "torso_lift_link", 7, left.reach) and isinstance(left.reach, float)
    grippers = {g.gripper: g for g in kb.gripper_opening("pr2")}
    assert (grippers["r_gripper"].arm, grippers["r_gripper"].cls) == ("r_arm", "ParallelGripper")
    assert grippers["r_gripper"].opening == pytest.approx(0.0938, abs=1e-4)
    assert kb.arm_reach("pr2_no_body") == [] and kb.gripper_opening("pr2_no_body")[0].opening == pytest.approx(0.0938, abs=1e-4)


@pytest.mark.slow
@pytest.mark.parametrize("name", ["camera_frames", "arm_reach", "gripper_opening"])
def test_oxigraph_agrees_with_rdflib_on_the_export(whole_pr2_store, name):
    variables, got, want = both_engines(whole_pr2_store, "pr2", name, {})

    def value(text):  # rdflib writes decimals in canonical form ("1.0" for "1"): compare them as numbers
        return Decimal(text) if re.fullmatch(r"-?[0-9]+(\.[0-9]+)?", text) else " ".join(sorted(text.split()))

    def norm(answer):
        return sorted((tuple(value(r[v]) if r.get(v) is not None else None for v in variables) for r in answer), key=str)

    assert got and norm(got) == norm(want)


class Page(HTMLParser):
    """The text of each component row's `sight` note and each body row's `reach` note, by row id."""

    def __init__(self, html: str):
        super().__init__()
        self.notes: dict[str, str] = {}
        self._row: str | None = None
        self._note: str | None = None
        self.feed(html)

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag == "tr" and a.get("id", "").startswith("row-"):
            self._row = a["id"][4:]
        elif tag == "div" and a.get("class") in ("muted sight", "muted reach") and self._row:
            self._note = self._row
            self.notes[self._row] = ""

    def handle_endtag(self, tag):
        if tag == "div":
            self._note = None

    def handle_data(self, data):
        if self._note:
            self.notes[self._note] += data


def test_the_review_page_shows_a_cameras_frames_and_field_of_view_and_an_arms_reach(url):
    status, ctype, body = http("GET", f"{url}/robots/pr2", headers=HTML)
    assert status == 200 and ctype.startswith("text/html")
    notes = {k: " ".join(v.split()) for k, v in Page(body.decode()).notes.items()}
    assert notes["comp_kinect"] == ("sees from head_mount_kinect_ir_optical_frame (depth frame), "
                                    "head_mount_kinect_rgb_optical_frame (RGB frame) · field of view 57° · 640×480 px")
    assert notes["comp_r_forearm_cam"] == "sees from r_forearm_cam_optical_frame (RGB frame) · field of view 90° · 640×480 px"
    assert notes["body_l_arm"] == "reaches 1.00 m · 7 degrees of freedom"
    assert "comp_base_laser" not in notes and "body_head" not in notes  # no camera, no arm
