"""Resource limits and stored text: bounded query answers, slow clients, robot names, free text.

Each case answered badly before: a 536 MB answer built in full, 100 trickling connections starving
every other client, a robot name ending in a newline stored, control characters or a lone surrogate
in a correction answering 500 or breaking the .owl export."""
import functools
import json
import random
import socket
import subprocess
import sys
import threading
import time
import urllib.parse
import xml.dom.minidom
from typing import Any

import pyoxigraph as ox
import pytest

from tests.kb_fixtures import copied, fake_runner, http, make_app, running
from urdfkb.kb_server import queries
from urdfkb.kb_server.cli import main
from urdfkb.kb_server.results import ResultLimits, ResultTooLarge, serialize
from urdfkb.kb_server.security import Policy
from urdfkb.kb_server.serve import make_server
from urdfkb.kb_server.store import RobotNameError, Store, check_robot_name
from urdfkb.pipeline.errors import UrdfkbError
from urdfkb.pipeline.runner import Settings

CROSS = "SELECT * { ?a ?p ?b . ?c ?q ?d } LIMIT 1200000"  # 536 MB of JSON over PR2 before the limits
XML = "application/xml"


@pytest.fixture(scope="module")
def pr2_path(pr2_kb, tmp_path_factory):
    """The module's store file holding PR2."""
    return copied(pr2_kb, tmp_path_factory.mktemp("kb"))


@pytest.fixture(scope="module")
def server(pr2_path):
    """A live `urdfkb serve` (make_server, default options) over the PR2 store; yields its base URL."""
    srv, store, jobs = make_server(pr2_path, port=0, runner=fake_runner())
    try:
        with running(srv):
            yield f"http://127.0.0.1:{srv.effective_port}"
    finally:
        jobs.shutdown()
        store.close()


# --- bounded query answers ---------------------------------------------------------------------


def query(base, text, accept=None, timeout=10):
    return http("GET", f"{base}/sparql?" + urllib.parse.urlencode({"query": text}),
                headers={"Accept": accept} if accept else {}, timeout=timeout)


def test_an_oversized_answer_is_refused_fast_without_building_it(server):
    started = time.monotonic()
    status, ctype, body = query(server, CROSS, timeout=5)
    took = time.monotonic() - started
    assert status == 413 and ctype.startswith("text/plain") and took < 5, (status, took)
    message = body.decode()
    assert "33,554,432 bytes" in message and "max-result-bytes" in message
    assert "LIMIT" in message and "OFFSET" in message


def test_an_answer_with_too_many_rows_is_refused_at_the_row_limit(server):
    started = time.monotonic()
    status, _, body = query(server, CROSS.replace("*", "?unbound"), "text/csv", timeout=5)  # 3-byte rows
    assert status == 413 and time.monotonic() - started < 5
    assert "more than 100,000 rows" in body.decode() and "max-result-rows" in body.decode()
    status, _, body = query(server, CROSS.replace("1200000", "100000").replace("*", "?unbound"), "text/csv")
    assert status == 200 and body.count(b"\r\n") == 100_001  # the header and exactly the limit


def _nasty_store(rows: int) -> ox.Store:
    """Literals full of what a row counter could take for a row, in rows that straddle the writer's chunks."""
    pieces = ['a,{b', '"', '\\', '\\"', 'x\\\\"', '<result>', '\n', '\r\n', '[{', '","', '\\\\', '\t', ',{"', '{}']
    rng = random.Random(7)
    store = ox.Store()
    for i in range(rows):
        text = "".join(rng.choice(pieces) for _ in range(rng.randint(0, 30))) + "z" * rng.randint(0, 60)
        store.add(ox.Quad(ox.NamedNode(f"http://e/s{i}"), ox.NamedNode("http://e/p"),
                          ox.BlankNode() if i % 5 == 0 else ox.Literal(text)))
    return store


@pytest.mark.parametrize("fmt", ["JSON", "XML", "CSV", "TSV", "TURTLE", "RDF_XML", "N_TRIPLES"])
def test_rows_are_counted_exactly_in_every_format(fmt):
    rows, store = 2_000, _nasty_store(2_000)
    text, fmt = (("SELECT * { ?s ?p ?o }", getattr(ox.QueryResultsFormat, fmt)) if hasattr(ox.QueryResultsFormat, fmt)
                 else ("CONSTRUCT WHERE { ?s ?p ?o }", getattr(ox.RdfFormat, fmt)))
    plain = store.query(text).serialize(format=fmt)
    assert serialize(store.query(text), fmt, ResultLimits(rows=rows)) == plain
    with pytest.raises(ResultTooLarge, match="more than 1,999 (rows|triples)"):
        serialize(store.query(text), fmt, ResultLimits(rows=rows - 1))
    with pytest.raises(ResultTooLarge, match=f"larger than {len(plain) - 1:,} bytes"):
        serialize(store.query(text), fmt, ResultLimits(bytes=len(plain) - 1))


def test_named_queries_and_the_cli_answer_within_the_same_limits(pr2_path, monkeypatch, capsys):
    store = Store(pr2_path, limits=ResultLimits(rows=3))
    app, jobs = make_app(store)
    try:
        r = app.test_client().get("/queries/components?robot=pr2")
        assert r.status_code == 413 and b"more than 3 rows" in r.data
    finally:
        jobs.shutdown()
        store.close()
    monkeypatch.setattr(queries, "Store", functools.partial(Store, limits=ResultLimits(rows=3)))
    assert main(["query", "components", "--robot", "pr2", "--store", str(pr2_path)]) == 2
    assert "urdfkb: error: the answer has more than 3 rows" in capsys.readouterr().err


def test_limits_must_be_positive(tmp_path):
    for bad in (dict(rows=0), dict(bytes=-1)):
        with pytest.raises(UrdfkbError, match="must be positive"):
            ResultLimits(**bad)
    refused: list[dict[str, Any]] = [dict(max_connections=0), dict(channel_timeout=0), dict(header_timeout=0.5),
                                     dict(body_timeout=0)]
    for options in refused:
        with pytest.raises(UrdfkbError, match="at least 1"):
            make_server(tmp_path / "kb.sqlite3", port=0, **options)


# --- slow clients ------------------------------------------------------------------------------


def test_slow_clients_do_not_starve_the_others(server):
    """110 connections trickling a request body (a byte every 0.2 s) while another client asks."""
    host, port = urllib.parse.urlsplit(server).netloc.split(":")
    head = (f"POST /populate HTTP/1.1\r\nHost: {host}:{port}\r\nContent-Type: {XML}\r\n"
            "Content-Length: 100000\r\n\r\n").encode()
    slow: list[socket.socket] = []
    stop = threading.Event()
    trickler = threading.Thread(target=trickle, args=(slow, stop, b"<"), daemon=True)
    try:
        for _ in range(110):
            s = socket.create_connection((host, int(port)), timeout=2)
            s.sendall(head)
            slow.append(s)
        trickler.start()
        time.sleep(0.5)  # every slow connection accepted and sending
        started = time.monotonic()
        status, _, body = http("GET", f"{server}/robots", timeout=1)
        assert status == 200 and json.loads(body)[0]["name"] == "pr2"
        assert time.monotonic() - started < 1
    finally:
        stop_trickling(trickler, stop, slow)


def trickle(slow: list[socket.socket], stop: threading.Event, byte: bytes) -> None:
    """Send `byte` on every socket of `slow` every 0.2 s (never idle), until `stop` is set."""
    while not stop.wait(0.2):
        for s in slow:
            try:
                s.send(byte)
            except OSError:
                pass


def stop_trickling(trickler: threading.Thread, stop: threading.Event, slow: list[socket.socket]) -> None:
    stop.set()
    if trickler.is_alive():
        trickler.join(2)
    for s in slow:
        s.close()


def closed(s: socket.socket) -> bool:
    """Whether the server has closed `s` (a FIN or a reset), waiting at most 0.1 s for it."""
    s.settimeout(0.1)
    try:
        return s.recv(1) == b""
    except socket.timeout:
        return False
    except OSError:
        return True


@pytest.mark.slow
def test_trickling_clients_are_cut_off_at_the_deadline_and_never_keep_another_out(tmp_path):
    """40 clients trickling headers or a body (a byte every 0.2 s: never idle) against a limit of 20
    connections: another client is answered at once, before any deadline (the oldest trickler makes room),
    and every trickler is closed soon after its deadline. They held their connections for good, and
    the others waited in the backlog."""
    srv, store, jobs = make_server(tmp_path / "kb.sqlite3", port=0, runner=fake_runner(), max_connections=20,
                                   header_timeout=3, body_timeout=3)
    port, stop = srv.effective_port, threading.Event()
    slow: list[socket.socket] = []
    heads = (b"GET /robots HTTP/1.1\r\nX-Slow: ",
             f"POST /populate HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nContent-Type: {XML}\r\n"
             "Content-Length: 100000\r\n\r\n".encode())
    trickler = threading.Thread(target=trickle, args=(slow, stop, b"a"), daemon=True)
    try:
        with running(srv):
            for i in range(40):
                s = socket.create_connection(("127.0.0.1", port), timeout=2)
                s.sendall(heads[i % 2])
                slow.append(s)
            trickler.start()
            time.sleep(0.5)
            started = time.monotonic()
            status, _, body = http("GET", f"http://127.0.0.1:{port}/robots", timeout=2)
            assert status == 200 and json.loads(body) == [] and time.monotonic() - started < 1
            deadline = time.monotonic() + 10
            while (left := [s for s in slow if not closed(s)]) and time.monotonic() < deadline:
                pass
            assert not left, f"{len(left)} trickling connections still open"
    finally:
        stop_trickling(trickler, stop, slow)
        jobs.shutdown()
        store.close()


def test_a_body_over_the_size_limit_is_refused_before_it_is_buffered(server):
    """waitress buffered up to 1 GB of a request before the app could refuse it; now 10 MB at most."""
    host, port = urllib.parse.urlsplit(server).netloc.split(":")
    with socket.create_connection((host, int(port)), timeout=5) as s:
        s.sendall(f"POST /populate HTTP/1.1\r\nHost: {host}:{port}\r\nContent-Type: {XML}\r\n"
                  "Content-Length: 10000001\r\n\r\n".encode())
        assert s.recv(100).startswith(b"HTTP/1.1 413 ")  # at once, with no byte of the body sent


@pytest.mark.slow
def test_an_idle_connection_is_closed_after_the_channel_timeout(tmp_path):
    srv, store, jobs = make_server(tmp_path / "kb.sqlite3", port=0, runner=fake_runner(), channel_timeout=1)
    try:
        with running(srv), socket.create_connection(("127.0.0.1", srv.effective_port), timeout=5) as idle:
            started = time.monotonic()
            assert idle.recv(1) == b""  # closed by the server, not by the 5 s timeout
            assert 1 <= time.monotonic() - started < 4
    finally:
        jobs.shutdown()
        store.close()


@pytest.mark.slow
def test_the_open_files_limit_is_raised_for_the_connections():
    """In a child process: a soft limit of 512 is raised to fit 1,000 connections; a hard limit of
    600 fits fewer, which the server then accepts instead (with a warning)."""
    code = """if True:
        import resource
        from urdfkb.kb_server.serve import FD_RESERVE, open_files_for
        hard = resource.getrlimit(resource.RLIMIT_NOFILE)[1]
        resource.setrlimit(resource.RLIMIT_NOFILE, (512, hard))
        print(open_files_for(1000), resource.getrlimit(resource.RLIMIT_NOFILE)[0] >= 2 * 1000 + FD_RESERVE)
        resource.setrlimit(resource.RLIMIT_NOFILE, (512, 600))
        print(open_files_for(1000), resource.getrlimit(resource.RLIMIT_NOFILE)[0])
    """
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["1000", "True", str((600 - 256) // 2), "600"]


# --- robot names and stored text ---------------------------------------------------------------


@pytest.fixture
def api(tmp_path, shared):
    """The app (test client) with PR2 populated from its URDF, so it takes corrections."""
    store = Store(tmp_path / "kb.sqlite3", workers=0)
    app, jobs = make_app(store)
    c = app.test_client()
    r = c.post("/populate", data=(shared / "urdf" / "pr2.urdf").read_bytes(), content_type=XML)
    assert jobs.get(r.get_json()["id"]).wait(30)
    yield c
    jobs.shutdown()
    store.close()


def test_a_robot_name_ending_in_a_newline_is_refused(api, shared):
    with pytest.raises(RobotNameError):
        check_robot_name("pr2\n")
    r = api.post("/populate?name=pr2%0A", data=(shared / "urdf" / "pr2.urdf").read_bytes(), content_type=XML)
    assert r.status_code == 400 and "robot name" in r.get_json()["error"]
    assert [e["name"] for e in api.get("/robots").get_json()] == ["pr2"]


def correct(api, **fields):
    body = json.dumps({"action": "confirm", "links": ["base_laser_link"], **fields})
    return api.post("/robots/pr2/corrections", data=body, content_type="application/json")


def test_a_reviewer_name_with_control_characters_is_refused_and_the_export_stays_xml(api):
    r = correct(api, reviewer="Ann\x01\x7f")
    assert r.status_code == 400 and "reviewer" in r.get_json()["error"] and "U+0001" in r.get_json()["error"]
    r = correct(api, reviewer="Ann\tReviewer\n")  # whitespace runs are one space, as before
    assert r.status_code == 201 and r.get_json()["correction"]["reviewer"] == "Ann Reviewer"
    xml.dom.minidom.parseString(api.get("/robots/pr2.owl").data)


def test_a_reviewer_with_a_lone_surrogate_is_a_400_naming_the_field(api):
    r = correct(api, reviewer="\ud800")  # json.dumps writes it as the escape "\ud800"
    assert r.status_code == 400 and "reviewer" in r.get_json()["error"] and "U+D800" in r.get_json()["error"]
    assert api.get("/robots/pr2/corrections").get_json()["applied"] == []


@pytest.mark.parametrize("reviewer", ["Ann \u202eeiv\u202c", "\u2066Bob\u2069", "A\u200db"])
def test_a_reviewer_with_a_bidi_or_zero_width_character_is_refused(api, reviewer):
    """U+202E (right-to-left override) and U+2066 (an isolate) make a name display as another; ZWJ is
    refused with them (Unicode category Cf)."""
    r = correct(api, reviewer=reviewer)
    assert r.status_code == 400 and "reviewer" in r.get_json()["error"] and "format characters" in r.get_json()["error"]
    assert api.get("/robots/pr2/corrections").get_json()["applied"] == []


def test_deeply_nested_json_is_a_400_not_a_500(api):
    """100,000 nested arrays made json.loads raise RecursionError."""
    r = api.post("/robots/pr2/corrections", data="[" * 100_000 + "]" * 100_000, content_type="application/json")
    assert r.status_code == 400 and "nested deeper than 32 levels" in r.get_json()["error"]
    r = api.post("/robots/pr2/corrections", data='{"action": "confirm", "links": ["base_laser_link"], '
                 '"reviewer": "[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[["}', content_type="application/json")
    assert r.status_code == 201  # brackets inside a string do not nest
    r = api.post("/robots/pr2/corrections", data='{"action": ', content_type="application/json")
    assert r.status_code == 400 and r.get_json()["error"].startswith("the body is not JSON")


@pytest.mark.parametrize("field, value", [("class", {"name": "Lidar"}), ("class", ["Lidar"]), ("mount", 7),
                                          ("reviewer", 42), ("reviewer", ["Ann"])])
def test_a_field_of_the_wrong_json_type_is_a_400_naming_it(api, field, value):
    r = correct(api, action="add" if field == "class" else "remount" if field == "mount" else "confirm",
                **{field: value})
    assert r.status_code == 400 and r.get_json()["error"].startswith(f"{field} must be a string")


def test_a_model_name_with_control_characters_is_refused(tmp_path, shared):
    """llm_model is stored with the robot (its abstractionModel): refused before anything is queued."""
    policy = Policy(llm_urls=["http://llm.lan/v1"])
    assert policy.check_settings(Settings(llm_url="http://llm.lan/v1", llm_model="qwen2.5:1.5b")).llm_model
    store = Store(tmp_path / "kb.sqlite3", workers=0)
    app, jobs = make_app(store, policy=policy)
    try:
        r = app.test_client().post("/populate?" + urllib.parse.urlencode(
            {"llm_url": "http://llm.lan/v1", "llm_model": "qwen\x00<evil/>", "vote": "sample"}),
            data=(shared / "urdf" / "pr2.urdf").read_bytes(), content_type=XML)
        assert r.status_code == 400 and "llm_model must be text without control characters" in r.get_json()["error"]
    finally:
        jobs.shutdown()
        store.close()
