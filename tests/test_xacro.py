"""xacro input: an invented rover with a package include and arguments, from the CLI and over HTTP;
hostile documents refused with file and line, nothing stored."""
from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.kb_fixtures import client, make_app, multipart
from urdfkb.kb_server.cli import main
from urdfkb.kb_server.store import Store
from urdfkb.pipeline.reading import sandbox
from urdfkb.pipeline.errors import URDFError
from urdfkb.pipeline.reading.xacro_input import XacroError, expand, load_description, parse_args, parse_package_paths

DATA = Path(__file__).parent / "data" / "xacro"
ROVER = DATA / "main" / "rover.urdf.xacro"
PACKAGES = {"quokka_parts": DATA / "parts_pkg"}
XNS = 'xmlns:xacro="http://www.ros.org/wiki/xacro"'


def doc(body: str) -> bytes:
    return f'<robot name="hostile" {XNS}>\n{body}\n</robot>'.encode()


def test_rover_expands_with_includes_and_arguments():
    tree = load_description(ROVER, packages=PACKAGES, args={"prefix": "zz"})
    assert tree.robot_name == "quokka_rover"
    assert set(tree.links) == {"zz_footprint", "zz_body", "zz_snoutcam_link", "zz_snoutcam_color_optical_frame"}
    no_cam = load_description(ROVER, packages=PACKAGES, args={"with_camera": "false"})
    assert set(no_cam.links) == {"qk_footprint", "qk_body"}


def test_the_tree_records_the_digest_of_the_expanded_urdf_not_of_the_xacro_source():
    import hashlib
    tree = load_description(ROVER, packages=PACKAGES, args={"prefix": "zz"})
    urdf = expand(ROVER.read_bytes(), ROVER.name, main_dir=ROVER.parent, args={"prefix": "zz"}, packages=PACKAGES)
    assert tree.source_sha256 == hashlib.sha256(urdf).hexdigest() != hashlib.sha256(ROVER.read_bytes()).hexdigest()


def test_argument_and_package_path_syntax():
    assert parse_args(["a:=1", "b_c:=x y"]) == {"a": "1", "b_c": "x y"}
    with pytest.raises(XacroError, match="NAME:=VALUE"):
        parse_args(["a=1"])
    with pytest.raises(XacroError, match="no such directory"):
        parse_package_paths(["ghost=/nonexistent/dir"])


@pytest.mark.parametrize("body, message", [
    ('<xacro:include filename="/etc/hostname"/>', "hostile.urdf.xacro:2: include 'hostname' is outside the allowed directories"),
    ('<xacro:include filename="$(find quokka_parts)/../../../../etc/passwd"/>', "outside the allowed directories"),
    ('<xacro:include filename="$(find ghost)/x.xacro"/>', "hostile.urdf.xacro:2: $(find ghost): unknown package"),
    ('<xacro:include filename="package://ghost/x.xacro"/>', "unknown package 'ghost'"),
    ('<xacro:include filename="missing.xacro"/>', "outside the allowed directories"),
    ('<link name="$(eval open(\'/etc/passwd\').read())"/>', "$(eval ...) is not supported"),
    ('<link name="$(env HOME)"/>', "$(env HOME) is not available"),
    ('<link name="${xacro.load_yaml(\'/etc/passwd\')}"/>', "outside the allowed directories"),
    ('<link name="${nowhere}"/>', "hostile.urdf.xacro:2: name 'nowhere' is not defined"),
    ('<xacro:macro name="loop" params=""><xacro:loop/></xacro:macro>\n<xacro:loop/>', "hostile.urdf.xacro:3: macros nested deeper"),
    ('<xacro:undefined_macro/>', "hostile.urdf.xacro:2: unknown macro name"),
    ('<link name="x">', "hostile.urdf.xacro:3: not well-formed XML"),
])
def test_hostile_or_broken_xacro_is_refused_naming_file_and_line(body, message):
    with pytest.raises(XacroError) as err:
        load_description(doc(body), filename="hostile.urdf.xacro", packages=PACKAGES)
    assert message in str(err.value)


@pytest.mark.slow
def test_include_loops_oversize_and_runaway_expressions_are_bounded(tmp_path):
    loop = tmp_path / "loop.urdf.xacro"
    loop.write_text(f'<robot name="l" {XNS}><xacro:include filename="loop.urdf.xacro"/></robot>')
    with pytest.raises(XacroError, match="includes nested deeper"):
        load_description(loop)
    missing = tmp_path / "missing.urdf.xacro"
    missing.write_text(f'<robot name="m" {XNS}>\n\n<xacro:include filename="nothere.xacro"/></robot>')
    with pytest.raises(XacroError, match=r"missing.urdf.xacro:3: cannot read include .*nothere.xacro"):
        load_description(missing)
    with pytest.raises(XacroError, match="byte limit"):
        load_description(doc('<link name="${\'x\' * 300000}"/>'), filename="big.xacro", max_bytes=200_000)
    with pytest.raises(XacroError, match="longer than 2 s|CPU or memory limit"):
        expand(doc('<link name="${9**9**9}"/>'), "slow.xacro", timeout=2)


def test_cli_populates_a_xacro_robot(tmp_path, capsys):
    out = tmp_path / "rover.ttl"
    code = main(["populate", str(ROVER), "--structure-only", "--format", "turtle", "-o", str(out), "-q",
                 "--xacro-arg", "prefix:=cli", "--package-path", f"quokka_parts={PACKAGES['quokka_parts']}"])
    assert code == 0 and "cli_snoutcam_color_optical_frame" in out.read_text()
    code = main(["populate", str(ROVER), "--structure-only", "-o", str(tmp_path / "x.owl"), "-q"])
    err = capsys.readouterr().err
    assert code == 2 and "urdfkb: error: rover.urdf.xacro:7: $(find quokka_parts): unknown package" in err
    assert not (tmp_path / "x.owl").exists()


def _job(api, body: bytes, headers: dict, query: str = "") -> dict:
    """POST /populate (accepted at once: expansion is the job's work) and the finished job."""
    status, _, out = api("POST", "/populate" + query, body, headers)
    assert status == 202, out
    return json.loads(api("GET", f"/jobs/{json.loads(out)['id']}?wait=1")[2])


@pytest.mark.skipif(bool(sandbox.unavailable()), reason=f"no xacro sandbox here: {sandbox.unavailable()}")
@pytest.mark.slow  # over a second of its own (make test-fast leaves it out)
def test_http_populate_of_xacro_reads_only_configured_packages(tmp_path):
    store = Store(tmp_path / "kb.sqlite3")
    rover = ROVER.read_bytes()
    form = {"X-Requested-With": "urdfkb-tests"}
    try:
        app, jobs = make_app(store)  # no package paths: the upload can include nothing
        api = client(app)
        body, ctype = multipart({"structure_only": "true"}, {"urdf": ("rover.urdf.xacro", rover)})
        job = _job(api, body, {"Content-Type": ctype, **form})
        assert job["state"] == "failed" and job["robot"] is None
        assert "cannot expand the xacro: rover.urdf.xacro:7" in job["errors"][0]
        assert store.robots() == []
        jobs.shutdown()
        app, jobs = make_app(store, package_paths=PACKAGES)
        api = client(app)
        # the upload's own folder is not readable: chassis.xacro must come from a package too
        job = _job(api, body, {"Content-Type": ctype, **form})
        assert job["state"] == "failed" and "chassis.xacro" in job["errors"][0]
        flat = rover.replace(b'<xacro:include filename="chassis.xacro"/>',
                             b'<xacro:include filename="package://quokka_parts/../main/chassis.xacro"/>')
        body, ctype = multipart({}, {"urdf": ("r.urdf.xacro", flat)})
        job = _job(api, body, {"Content-Type": ctype, **form})
        assert job["state"] == "failed" and "outside the allowed directories" in job["errors"][0]
        assert str(DATA) not in job["errors"][0]  # the sandbox's paths, never the server's
        chassis = (DATA / "main" / "chassis.xacro").read_bytes()
        inline = rover.replace(b'<xacro:include filename="chassis.xacro"/>', chassis.split(b"?>", 1)[1]
                               .replace(b"<robot", b"<xacro:if value=\"true\"").replace(b"</robot>", b"</xacro:if>"))
        job = _job(api, inline, {"Content-Type": "application/xml"}, "?xacro_arg=prefix:=web&structure_only=true")
        assert job["state"] == "succeeded" and job["robot"] == "quokka_rover"
        robot = json.loads(api("GET", "/robots/quokka_rover")[2])
        assert robot["name"] == "quokka_rover"
        jobs.shutdown()
    finally:
        store.close()


def test_the_xacro_time_limit_is_set_by_serve_xacro_timeout(tmp_path, monkeypatch):
    from urdfkb.kb_server import serve
    from urdfkb.kb_server.cli import _limits, build_parser
    from urdfkb.pipeline.errors import UrdfkbError
    assert _limits(build_parser().parse_args(["serve", "--xacro-timeout", "2.5"]))["xacro_timeout"] == 2.5
    real, apps = serve.create_app, []

    def spy(*args, **kwargs):
        apps.append(real(*args, **kwargs))
        return apps[-1]
    monkeypatch.setattr(serve, "create_app", spy)
    server, store, jobs = serve.make_server(tmp_path / "kb.sqlite3", port=0, xacro_timeout=2.5)
    try:
        assert apps[0].extensions["urdfkb"].xacro_timeout == 2.5
    finally:
        server.close()
        jobs.shutdown()
        store.close()
    with pytest.raises(UrdfkbError, match="--xacro-timeout"):
        serve.make_server(tmp_path / "kb.sqlite3", port=0, xacro_timeout=0)


def test_plain_urdf_with_xacro_arguments_is_an_error():
    with pytest.raises(URDFError, match="not a xacro file"):
        load_description(b'<robot name="r"><link name="a"/></robot>', filename="r.urdf", args={"x": "1"})
