"""The whole body on the review page: PR2 with its hand-written body (kb_fixtures.PR2_WHOLE, no model)."""
from __future__ import annotations

import re
from html.parser import HTMLParser

import pytest

from tests.kb_fixtures import PR2_ARM, PR2_WHOLE, client, make_app
from urdfkb.kb_server import palette
from urdfkb.pipeline.ingest import load_urdf

HTML = {"Accept": "text/html,application/xhtml+xml,application/xml;q=0.9,*/*;q=0.8"}


@pytest.fixture(scope="module")
def pr2_tree(shared):
    return load_urdf(shared / "urdf" / "pr2.urdf")


@pytest.fixture
def store(store, pr2_tree):
    store.replace_robot("pr2", pr2_tree, PR2_WHOLE)
    return store


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
        self._row = self._band = None
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
    part, side, mount, joints, on = page.rows["l_arm"]
    assert words(part)[:2] == ["Arm", "l_arm"] and side.strip() == "left" and mount.strip() == "torso_lift_link"
    assert words(joints) == [f"l_{j}_joint" for j in PR2_ARM]  # root-most first
    assert words(on) == ["l_gripper", "ParallelGripper"]
    part, side, _, joints, on = page.rows["head"]
    assert side.strip() == "" and words(joints) == ["head_pan_joint", "head_tilt_joint"]
    assert set(words(on)) == {"kinect", "RGBDCamera", "wide_stereo", "StereoCamera", "prosilica", "MonocularCamera"}
    assert "part of base" in page.rows["fl_caster_l_wheel"][0]
    # one band per part, a box under each of its links
    assert page.bands == {f"body_{p.name}": len(p.links) for p in PR2_WHOLE.body}
    arm = palette.body_swatch("Arm").colour
    assert len(re.findall(rf'class="joint"[^>]*style="stroke: {arm}', html.decode())) == 14  # both arms' joints
    assert html.decode().count('<text class="side"') == sum(len(p.links) for p in PR2_WHOLE.body if p.side)
