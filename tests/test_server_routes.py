"""Every route of the server through Flask's test client (status codes, content types, jobs, atomic
re-populate, limits), and the real `urdfkb serve` under waitress restarted over one store."""
import json
import subprocess
import sys
import threading
import time
import urllib.parse
import urllib.request
from pathlib import Path

import pytest
import rdflib

import urdfkb.kb_server.index as index_mod
from tests.kb_fixtures import PR2, client, copied, free_port, make_app, multipart
from urdfkb.kb_server.jobs import pipeline_runner
from urdfkb.kb_server.serve import make_server
from urdfkb.kb_server.store import Store
from urdfkb.pipeline.abstraction.components import Abstraction
from urdfkb.pipeline.errors import BackendError

REPO = Path(__file__).resolve().parents[1]

TOKEN = "t0ken"
AUTH = {"Authorization": f"Bearer {TOKEN}"}


EVENTS: list[tuple[str, bool]] = []  # (robot, structure_only) per runner entry and exit, in order
GATE = threading.Event()  # what a 'gated*' robot's runner waits for


def runner(tree, settings, progress):
    """By URDF robot name: 'slow*' takes 0.6 s, 'gated*' waits for GATE, 'broken*' fails, '*half_pr2'
    gets three of the PR2 abstraction's components, '*pr2' all of them. Entries and exits go to EVENTS."""
    EVENTS.append(("enter", settings.structure_only))
    for i in range(3):
        progress("classify", i, 3)
        time.sleep(0.2 if tree.robot_name.startswith("slow") else 0)
    if tree.robot_name.startswith("gated"):
        assert GATE.wait(60), "the test never opened the gate"
    EVENTS.append(("exit", settings.structure_only))
    if tree.robot_name.startswith("broken"):
        raise BackendError("classification failed: model said 'banana'")
    if settings.structure_only:
        return pipeline_runner(tree, settings, progress)
    if tree.robot_name.endswith("half_pr2"):
        return Abstraction(PR2.components[:3])
    return PR2 if tree.robot_name.endswith("pr2") else Abstraction((), {"mode": "test"})


@pytest.fixture
def serve(tmp_path):
    """Starts the app over a new store with `workers` query processes (0: SPARQL in this process),
    through Flask's test client."""
    EVENTS.clear()
    GATE.clear()
    opened = []

    def start(workers: int = 0):
        store = Store(tmp_path / "kb.sqlite3", workers=workers)
        app, jobs = make_app(store, runner=runner, token=TOKEN, max_body=2_000_000)
        opened.append((store, jobs))
        return client(app)
    yield start
    for store, jobs in opened:
        jobs.shutdown()
        store.close()


@pytest.fixture
def server(serve):
    return serve()


def urdf(shared, name="pr2", rename=None) -> bytes:
    data = (shared / "urdf" / f"{name}.urdf").read_bytes()
    if rename:
        data = data.replace(f'<robot name="{name}"'.encode(), f'<robot name="{rename}"'.encode(), 1)
    return data


def populate(api, body, query="", headers=None):
    status, ctype, out = api("POST", f"/populate{query}", body, {**AUTH, **(headers or {})})
    return status, ctype, json.loads(out)


def wait(api, job_id):
    status, ctype, out = api("GET", f"/jobs/{job_id}?wait=1&timeout=30")
    assert status == 200 and ctype.startswith("application/json")
    return json.loads(out)


@pytest.mark.slow  # over a second of its own (make test-fast leaves it out)
def test_populate_raw_and_multipart_then_robot_routes(server, shared):
    status, _, job = populate(server, urdf(shared), headers={"Content-Type": "application/xml"})
    assert status == 202 and job["state"] in ("queued", "running", "succeeded")
    done = wait(server, job["id"])
    assert done["state"] == "succeeded" and done["errors"] == [] and done["ontology"] == "https://w3id.org/urdfkb/robot/pr2#"
    body, ctype = multipart({"name": "panda_a", "structure_only": "true"}, {"urdf": ("panda.urdf", urdf(shared, "panda"))})
    status, _, job = populate(server, body, headers={"Content-Type": ctype})
    assert status == 202 and wait(server, job["id"])["state"] == "succeeded"

    status, ctype, out = server("GET", "/robots")
    assert status == 200 and ctype.startswith("application/json")
    assert [r["name"] for r in json.loads(out)] == ["panda_a", "pr2"]
    status, ctype, out = server("GET", "/robots/pr2")
    assert status == 200 and ctype.startswith("application/json")
    comps = {c["iri"].split("#comp_")[1]: c for c in json.loads(out)["components"]}
    kinect = comps["kinect"]
    assert (kinect["class"], kinect["confidence"], kinect["mount"]) == ("RGBDCamera", 0.93, "head_mount_link")
    assert {(s["class"], s["link"]) for s in kinect["subcomponents"]} == {
        ("RgbFrame", "head_mount_kinect_rgb_optical_frame"), ("DepthFrame", "head_mount_kinect_ir_optical_frame"),
        ("SensorHousing", "head_mount_kinect_ir_link")}
    assert json.loads(server("GET", "/robots/panda_a")[2])["components"] == []

    for ext, ctype_want, fmt in (("owl", "application/rdf+xml", "xml"), ("ttl", "text/turtle", "turtle")):
        status, ctype, out = server("GET", f"/robots/pr2.{ext}")
        assert status == 200 and ctype.startswith(ctype_want)
        assert len(rdflib.Graph().parse(data=out, format=fmt)) > 1000
    assert server("GET", "/robots/pr2.pdf")[0] == 404


def test_bad_input(server, shared):
    status, ctype, job = populate(server, b"<html><body>hi</body></html>")  # parsed in its job, off the request thread
    assert status == 202
    done = wait(server, job["id"])
    assert done["state"] == "failed" and "not a valid URDF" in done["errors"][0] and done["stage"] == "load"
    status, _, out = populate(server, b"x" * 2_000_001)
    assert status == 413
    status, _, out = populate(server, urdf(shared), "?votes=many")
    assert status == 400 and "votes" in out["error"]
    status, _, out = populate(server, urdf(shared), "?colour=blue")
    assert status == 400 and "colour" in out["error"]
    status, _, out = populate(server, urdf(shared), "?name=bad%20name")
    assert status == 400 and "name" in out["error"]
    assert server("POST", "/populate", urdf(shared))[0] == 403  # token configured, none sent
    for path in ("/robots/nope", "/robots/nope.ttl", "/jobs/nope", "/queries/cameras?robot=nope", "/queries/nope?robot=x", "/nowhere"):
        status, ctype, _ = server("GET", path)
        assert status == 404 and ctype.startswith("application/json"), path


def test_a_robot_whose_root_is_its_only_leaf_fails_its_job_with_a_clear_error(store):
    app, jobs = make_app(store, runner=pipeline_runner)  # the real runner: it refuses before any model loads
    api = client(app)
    try:
        lonely = b'<robot name="lonely"><link name="only"/></robot>'
        status, _, out = api("POST", "/populate", lonely, {"Content-Type": "application/xml"})
        assert status == 202
        job = wait(api, json.loads(out)["id"])
        assert job["state"] == "failed" and store.robots() == []
        assert job["errors"] == ["robot 'lonely' has a single link, 'only': no device to abstract "
                                 "(--structure-only writes its structure) (at link 'only')"]
        status, _, out = api("POST", "/populate?structure_only=true", lonely, {"Content-Type": "application/xml"})
        assert wait(api, json.loads(out)["id"])["state"] == "succeeded"
    finally:
        jobs.shutdown()


def test_failed_job_leaves_the_store_as_it_was(server, shared):
    wait(server, populate(server, urdf(shared))[2]["id"])
    before = server("GET", "/robots/pr2")[2]
    job = wait(server, populate(server, urdf(shared, rename="broken"), "?name=pr2")[2]["id"])
    assert job["state"] == "failed" and "banana" in job["errors"][0]
    assert server("GET", "/robots/pr2")[2] == before


@pytest.mark.slow  # over a second of its own (make test-fast leaves it out)
def test_queries_answered_while_a_model_runs_and_jobs_report_progress(server, shared):
    wait(server, populate(server, urdf(shared))[2]["id"])
    job = populate(server, urdf(shared, rename="gated_pr2"), "?name=pr2")[2]
    end = time.monotonic() + 30
    while (state := json.loads(server("GET", f"/jobs/{job['id']}")[2]))["stage"] != "classify":
        assert state["state"] in ("queued", "running") and time.monotonic() < end, state
        time.sleep(0.01)
    assert state["state"] == "running" and state["progress"]["total"] == 3
    for _ in range(3):  # the job cannot end before the gate opens: these are answered while it runs
        status, _, out = server("GET", "/queries/cameras?robot=pr2")
        assert status == 200 and len(json.loads(out)["results"]["bindings"]) == 7
    assert json.loads(server("GET", f"/jobs/{job['id']}")[2])["state"] == "running"
    GATE.set()
    assert wait(server, job["id"])["state"] == "succeeded"


COMPONENTS = """PREFIX core: <https://w3id.org/urdfkb/core#>
SELECT ?c ?class ?link WHERE { <https://w3id.org/urdfkb/robot/pr2#robot> core:hasComponent ?c .
  ?c a ?class ; core:hasComponent/core:hasLink/core:urdfName ?link } ORDER BY ?c ?class ?link"""


@pytest.mark.slow  # over a second of its own (make test-fast leaves it out)
def test_a_reader_sees_the_old_robot_or_the_new_one_never_a_mix(serve, shared, monkeypatch):
    """SPARQL readers (who never take the store lock) poll PR2's components while a re-populate replaces
    them by three of them. They must see the old robot, then the new one, and nothing between:
    no 404, no empty or partial component list, although this process's copy of the index is left
    without the robot's graph for a while in the middle of the replacement. The query workers (as
    served) apply a replacement whole between two queries; without them a reader sees the gap."""
    real_put = index_mod.put_graph

    def put_with_a_gap(store, graph, data):
        real_put(store, graph, None)
        time.sleep(0.3)
        real_put(store, graph, data)

    monkeypatch.setattr(index_mod, "put_graph", put_with_a_gap)
    api = serve(workers=2)
    wait(api, populate(api, urdf(shared))[2]["id"])

    def look() -> str:
        status, _, out = api("GET", "/sparql?" + urllib.parse.urlencode({"query": COMPONENTS}))
        return json.dumps(json.loads(out)["results"]["bindings"]) if status == 200 else f"status {status}"

    old = look()
    job = populate(api, urdf(shared, rename="gated_half_pr2"), "?name=pr2")[2]
    seen, stop, end = [], threading.Event(), time.monotonic() + 60

    def read():
        while not stop.is_set() and time.monotonic() < end:
            seen.append(look())
            time.sleep(0.005)  # a client's pace: back-to-back queries with no pause can starve the writer here

    reader = threading.Thread(target=read)
    reader.start()
    try:
        while not seen and time.monotonic() < end:  # the reader is under way before the write
            time.sleep(0.01)
        GATE.set()
        assert wait(api, job["id"])["state"] == "succeeded"
        new = look()
        while (not seen or seen[-1] != new) and time.monotonic() < end:  # and on until it has seen the write
            time.sleep(0.01)
    finally:
        stop.set()
        reader.join(10)
    assert (len({row["c"]["value"] for row in json.loads(old)}), len({row["c"]["value"] for row in json.loads(new)})) \
        == (len(PR2.components), 3)
    assert set(seen) == {old, new} and seen.index(new) > seen.index(old)
    assert seen[seen.index(new):] == [new] * (len(seen) - seen.index(new))  # never back to the old robot


@pytest.mark.slow  # over a second of its own (make test-fast leaves it out)
def test_same_robot_jobs_are_serialised(server, shared):
    wait(server, populate(server, urdf(shared))[2]["id"])
    EVENTS.clear()
    # Two slow jobs for the same robot at once (two job workers): structure-only and full.
    ids = [populate(server, urdf(shared, rename="slow_pr2"), "?name=pr2&structure_only=" + s)[2]["id"] for s in ("true", "false")]
    assert [wait(server, i)["state"] for i in ids] == ["succeeded", "succeeded"]
    # serialised: each job's runner exits before the other's enters
    assert [e for e, _ in EVENTS] == ["enter", "exit", "enter", "exit"] and EVENTS[0][1] == EVENTS[1][1]


def test_delete_needs_the_token(server, shared):
    wait(server, populate(server, urdf(shared))[2]["id"])
    assert server("DELETE", "/robots/pr2")[0] == 403
    status, ctype, out = server("DELETE", "/robots/pr2", headers=AUTH)
    assert status == 200 and json.loads(out)["deleted"] == "pr2"
    assert server("DELETE", "/robots/pr2", headers=AUTH)[0] == 404
    assert server("GET", "/robots/pr2")[0] == 404


def test_binds_loopback_by_default(tmp_path):
    server, store, jobs = make_server(tmp_path / "kb.sqlite3", port=0)
    assert server.effective_host == "127.0.0.1"
    server.close()
    jobs.shutdown()
    store.close()


@pytest.mark.slow
def test_urdfkb_serve_restart_serves_what_was_stored(tmp_path, pr2_kb):
    """The real entry point (urdfkb serve, waitress) in a subprocess, restarted over the same store."""
    path = copied(pr2_kb, tmp_path)
    for run in range(2):
        port, log = free_port(), tmp_path / f"serve{run}.log"
        with log.open("wb") as err:
            proc = subprocess.Popen([sys.executable, "-m", "urdfkb", "serve", "--store", str(path),
                                     "--port", str(port)], cwd=REPO, stderr=err)
        try:
            for _ in range(150):
                try:
                    with urllib.request.urlopen(f"http://127.0.0.1:{port}/robots/pr2", timeout=2) as r:
                        assert r.headers["Server"] == "waitress"
                        robot = json.loads(r.read())
                    break
                except OSError:
                    assert proc.poll() is None, log.read_text()
                    time.sleep(0.1)
            else:
                pytest.fail("urdfkb serve did not answer: " + log.read_text())
            assert len(robot["components"]) == len(PR2.components)
        finally:
            proc.terminate()
            proc.wait(10)


def test_queries_listing(server):
    status, ctype, out = server("GET", "/queries")
    assert status == 200 and ctype.startswith("application/json")
    assert {"cameras", "sensors", "mounted_below", "end_effectors", "low_confidence"} <= {q["name"] for q in json.loads(out)}
