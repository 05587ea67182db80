"""Mirroring robots as named graphs into a real Oxigraph server (SPARQL 1.1 Graph Store Protocol)."""
import json
import subprocess
import sys
import time
import urllib.parse
from pathlib import Path

import pytest
import rdflib

from tests.kb_fixtures import PR2, free_port, http, live, make_app, served
from urdfkb.kb_server.remote import RemoteError, RemoteStore
from urdfkb.kb_server.serve import make_server
from urdfkb.kb_server.store import Store
from urdfkb.pipeline.reading.ingest import load_urdf

pytestmark = pytest.mark.slow  # a real Oxigraph server process

OXIGRAPH = Path(sys.executable).with_name("oxigraph")
PR2_GRAPH = "https://w3id.org/urdfkb/robot/pr2#"
TOKEN = "tk"


@pytest.fixture(scope="module")
def oxigraph(tmp_path_factory):
    """A real Oxigraph server on a free loopback port; yields its base URL, stopped afterwards."""
    if not OXIGRAPH.exists():
        pytest.skip("oxigraph server binary not installed (pip install oxigraph)")
    port = free_port()
    proc = subprocess.Popen([str(OXIGRAPH), "serve", "--location", str(tmp_path_factory.mktemp("oxi")),
                             "--bind", f"127.0.0.1:{port}"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    base = f"http://127.0.0.1:{port}"
    try:
        for _ in range(100):
            try:
                if http("GET", base + "/", timeout=1)[0] < 500:
                    break
            except OSError:
                time.sleep(0.1)
        else:
            pytest.fail("oxigraph did not start")
        yield base
    finally:
        proc.terminate()
        proc.wait(10)


def remote_count(base, pattern):
    q = f"SELECT (COUNT(*) AS ?n) WHERE {{ {pattern} }}"
    status, _, out = http("GET", f"{base}/query?" + urllib.parse.urlencode({"query": q}),
                          headers={"Accept": "application/sparql-results+json"})
    assert status == 200
    return int(json.loads(out)["results"]["bindings"][0]["n"]["value"])


def graph_has_kinect(base):
    return remote_count(base, f"GRAPH <{PR2_GRAPH}> {{ <{PR2_GRAPH}comp_kinect> a ?c }}")


@pytest.fixture
def server(oxigraph, tmp_path):
    store = Store(tmp_path / "kb.sqlite3", workers=0)
    with served(store, token=TOKEN, remote=RemoteStore(oxigraph + "/store")) as base:
        yield base
    store.close()


def populate(base, shared, name="pr2"):
    status, _, out = http("POST", f"{base}/populate?name={name}", (shared / "urdf" / "pr2.urdf").read_bytes(),
                          {"Authorization": f"Bearer {TOKEN}"})
    assert status == 202
    return json.loads(http("GET", f"{base}/jobs/{json.loads(out)['id']}?wait=1&timeout=30")[2])


def test_populate_put_replaces_and_delete_drops_the_named_graph(server, oxigraph, shared):
    job = populate(server, shared)
    assert job["state"] == "succeeded", job
    assert graph_has_kinect(oxigraph) >= 1
    # self-contained graph: subclass reasoning works remotely within the robot's graph
    cams = f"""GRAPH <{PR2_GRAPH}> {{ ?c a ?k . ?k <http://www.w3.org/2000/01/rdf-schema#subClassOf>*
               <https://w3id.org/urdfkb/core#Camera> . <{PR2_GRAPH}robot> <https://w3id.org/urdfkb/core#hasComponent> ?c }}"""
    assert remote_count(oxigraph, cams) == 4
    size = remote_count(oxigraph, f"GRAPH <{PR2_GRAPH}> {{ ?s ?p ?o }}")
    assert populate(server, shared)["state"] == "succeeded"
    assert remote_count(oxigraph, f"GRAPH <{PR2_GRAPH}> {{ ?s ?p ?o }}") == size  # replaced, not appended
    status, _, out = http("DELETE", f"{server}/robots/pr2", headers={"Authorization": f"Bearer {TOKEN}"})
    assert status == 200 and json.loads(out)["mirror_error"] is None
    assert remote_count(oxigraph, f"GRAPH <{PR2_GRAPH}> {{ ?s ?p ?o }}") == 0


def test_startup_mirrors_robots_stored_before(oxigraph, shared, tmp_path):
    store = Store(tmp_path / "kb.sqlite3", workers=0)
    store.replace_robot("pr2_early", load_urdf(shared / "urdf" / "pr2.urdf"), PR2)
    store.close()
    server, store, jobs = make_server(tmp_path / "kb.sqlite3", port=0, remote_store=oxigraph + "/store")
    pushed = jobs.mirror_all()  # a second full push, awaited (make_server started one too)
    assert pushed is not None
    pushed.result(60)
    graph = "https://w3id.org/urdfkb/robot/pr2_early#"
    assert remote_count(oxigraph, f"GRAPH <{graph}> {{ <{graph}comp_kinect> a ?c }}") >= 1
    server.close()
    jobs.shutdown()
    store.close()


def test_remote_down_is_reported_and_the_robot_is_stored(tmp_path, shared):
    store = Store(tmp_path / "kb.sqlite3", workers=0)
    app, jobs = make_app(store, token=TOKEN, remote=RemoteStore(f"http://127.0.0.1:{free_port()}/store", timeout=2))
    with live(app) as base:
        job = populate(base, shared)
        assert job["state"] == "mirror_failed" and "stored locally" in job["errors"][0]
        assert http("GET", f"{base}/robots/pr2")[0] == 200
        status, _, out = http("DELETE", f"{base}/robots/pr2", headers={"Authorization": f"Bearer {TOKEN}"})
        assert status == 200 and "remote" in json.loads(out)["mirror_error"]
    jobs.shutdown()
    store.close()


def test_bad_remote_url_and_http_errors(oxigraph):
    with pytest.raises(ValueError):
        RemoteStore("ftp://example.org/store")
    RemoteStore(oxigraph + "/store").delete_graph("urn:never:stored")  # absent graph: not an error
    with pytest.raises(RemoteError, match="HTTP 4"):
        RemoteStore(oxigraph + "/store").put_graph("not an iri", rdflib.Graph())
