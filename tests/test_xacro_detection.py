"""What counts as xacro: a document that uses it, not one that only declares its namespace (as the URDFs
xacro writes do). Every shared URDF populates over HTTP where no sandbox can run; a real xacro is refused."""
from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.kb_fixtures import client, make_app, multipart
from urdfkb.kb_server.store import Store
from urdfkb.pipeline.reading import sandbox
from urdfkb.pipeline.reading.xacro_input import is_xacro, uses_xacro

ROVER = Path(__file__).parent / "data" / "xacro" / "main" / "rover.urdf.xacro"
XNS = 'xmlns:xacro="http://www.ros.org/wiki/xacro"'
JOINT = '<link name="a"/><link name="b"/><joint name="j" type="fixed"><parent link="a"/><child link="b"/></joint>'
NO_BWRAP = "bubblewrap (bwrap) is not installed (Debian: apt-get install bubblewrap)"


def robot(body: str, ns: str = XNS) -> bytes:
    return f'<?xml version="1.0"?>\n<robot name="r" {ns}>{body}</robot>'.encode()


@pytest.mark.parametrize("doc, used", [
    (robot(JOINT), False),  # the declaration alone: what xacro writes into the URDFs it expands
    (robot(f'<!-- <xacro:include filename="$(find pkg)/a.xacro"/> ${{x}} -->{JOINT}'), False),
    (robot(f'<xacro:property name="n" value="a"/>{JOINT}'), True),
    (robot(f'<xacro:macro name="m"/>{JOINT}'), True),
    (robot(f'<link name="c" xacro:if="true"/>{JOINT}'), True),
    (robot(f'<link name="${{n}}"/>{JOINT}'), True),
    (robot(f'<link name="c"><visual><geometry><mesh filename="$(find pkg)/m.stl"/></geometry></visual></link>{JOINT}'),
     True),
    (robot(f'<gazebo><param>${{rate}}</param></gazebo>{JOINT}'), True),
    (robot(f'<gazebo><a>$</a><b>{{x}}</b></gazebo>{JOINT}'), False),  # "$" and "{" in two texts
    (robot(f'<link name="${{n}}"/>{JOINT}', ns=""), False),  # a half-expanded left-over, not declared
    (robot(f'<link name="${{n}}"/>{JOINT}', ns='xmlns:xacro="http://ros.org/wiki/xacro"'), True),
    (robot(f'<xacro:property name="n" value="a"/>{JOINT}', ns=""), True),  # undeclared, still what xacro expands
    (b'<!DOCTYPE robot [<!ENTITY e "${x}">]>' + robot(JOINT)[22:], False),  # the URDF reader refuses the DTD
    (robot('<link name="a" name="b"/><link name="${n}"/>'), False),  # not XML first: the URDF reader names where
    (robot('<link name="${n}"/><link name="a" name="b"/>'), True),  # xacro first: xacro names where
])
def test_a_document_is_xacro_when_it_uses_xacro(doc, used):
    assert uses_xacro(doc) is used
    assert is_xacro(None, doc) is used and is_xacro("arm.urdf", doc) is used
    assert is_xacro("arm.urdf.xacro", doc)


def test_the_rover_uses_xacro():
    assert uses_xacro(ROVER.read_bytes())


def test_no_shared_urdf_uses_xacro(shared):
    declaring = [p for p in (shared / "urdf").glob("*.urdf") if b"ros.org/wiki/xacro" in p.read_bytes()]
    assert len(declaring) == 14  # the declaration, without a use
    assert [p.name for p in sorted((shared / "urdf").glob("*.urdf")) if uses_xacro(p.read_bytes())] == []


@pytest.fixture
def no_sandbox(tmp_path, monkeypatch):
    """The app over a new store on a machine without bubblewrap (sandbox.unavailable says so)."""
    monkeypatch.setattr(sandbox, "unavailable", lambda: NO_BWRAP)
    store = Store(tmp_path / "kb.sqlite3")
    app, jobs = make_app(store)
    yield client(app), store
    jobs.shutdown()
    store.close()


@pytest.mark.slow
def test_every_shared_urdf_populates_where_no_sandbox_runs(shared, no_sandbox):
    api, store = no_sandbox
    form = {"X-Requested-With": "urdfkb-tests"}
    for i, path in enumerate(sorted((shared / "urdf").glob("*.urdf"))):
        name = f"u{i}"
        if i % 2:  # half raw, half as a named file: neither way makes a URDF a xacro
            status, _, out = api("POST", f"/populate?name={name}", path.read_bytes(), {"Content-Type": "application/xml"})
        else:
            body, ctype = multipart({"name": name}, {"urdf": (path.name, path.read_bytes())})
            status, _, out = api("POST", "/populate", body, {"Content-Type": ctype, **form})
        assert status == 202, (path.name, out)
        job = json.loads(api("GET", f"/jobs/{json.loads(out)['id']}?wait=1&timeout=60")[2])
        assert job["state"] == "succeeded" and job["errors"] == [], (path.name, job)
    assert len(store.robots()) == len(list((shared / "urdf").glob("*.urdf")))


@pytest.mark.parametrize("filename", [None, "rover.urdf.xacro"])
def test_a_real_xacro_is_refused_naming_bubblewrap_where_no_sandbox_runs(no_sandbox, filename):
    api, store = no_sandbox
    query = f"?filename={filename}" if filename else ""
    status, _, out = api("POST", f"/populate{query}", ROVER.read_bytes(), {"Content-Type": "application/xml"})
    assert status == 403
    message = json.loads(out)["error"]
    assert "bubblewrap (bwrap) is not installed" in message and "apt-get install bubblewrap" in message
    assert store.robots() == []
