"""kill -9 during a populate, an update, or a burst of readers: after restart nothing stored is lost,
nothing half-written exists, and queries answer as before.

The real server runs in a subprocess (tests/crash_server.py), whose hooks make a populate or an
update touch a marker file and sleep inside the store transaction; the test then kills it with SIGKILL.
"""
import json
import os
import signal
import subprocess
import sys
import threading
import time
import urllib.parse
from http.client import HTTPException
from pathlib import Path

import pytest

from tests.kb_fixtures import PR2, free_port, http

REPO = Path(__file__).resolve().parents[1]
pytestmark = pytest.mark.crash


class Server:
    def __init__(self, store: Path, marker: Path, hang_on: str = ""):
        self.port = free_port()
        self.base = f"http://127.0.0.1:{self.port}"
        self.marker = marker
        env = {**os.environ, "URDFKB_TEST_HANG_ON": hang_on, "URDFKB_TEST_MARKER": str(marker)}
        self.proc = subprocess.Popen([sys.executable, "-m", "tests.crash_server", str(store), str(self.port)],
                                     cwd=REPO, env=env)
        for _ in range(200):
            try:
                if http("GET", self.base + "/robots", timeout=1)[0] == 200:
                    return
            except OSError:
                time.sleep(0.1)
        self.kill()
        raise RuntimeError("server did not start")

    def populate(self, urdf: Path, query: str = "") -> str:
        status, _, out = http("POST", f"{self.base}/populate{query}", urdf.read_bytes(),
                              {"Content-Type": "application/xml", "Authorization": "Bearer t"})
        assert status == 202
        return json.loads(out)["id"]

    def update(self, text: str) -> int:
        try:
            return http("POST", self.base + "/sparql", text.encode(),
                        {"Content-Type": "application/sparql-update", "Authorization": "Bearer t"}, timeout=60)[0]
        except OSError:  # killed while answering
            return 0

    def answers(self) -> list[bytes]:
        return [http("GET", f"{self.base}/sparql?" + urllib.parse.urlencode({"query": q}))[2] for q in ANSWERS]

    def wait(self, job_id: str) -> dict:
        return json.loads(http("GET", f"{self.base}/jobs/{job_id}?wait=1&timeout=60")[2])

    def kill(self) -> None:
        os.kill(self.proc.pid, signal.SIGKILL)
        self.proc.wait(10)

    def crash_during(self, urdf: Path | None, query: str) -> None:
        """Populate (or, without a URDF, send update `query`), wait until it is inside the store
        transaction, then kill -9."""
        if urdf is None:
            threading.Thread(target=self.update, args=(query,), daemon=True).start()
        else:
            self.populate(urdf, query)
        for _ in range(300):
            if self.marker.exists():
                break
            time.sleep(0.05)
        assert self.marker.exists(), "the populate never reached the store transaction"
        self.kill()
        self.marker.unlink()


PR2_GRAPH = "https://w3id.org/urdfkb/robot/pr2#"
ANSWERS = ["SELECT ?g (COUNT(*) AS ?n) WHERE { GRAPH ?g { ?s ?p ?o } } GROUP BY ?g ORDER BY ?g",
           "SELECT ?s ?p ?o WHERE { ?s ?p ?o FILTER(isLiteral(?o) && CONTAINS(STR(?o), 'note')) } ORDER BY ?s ?p ?o",
           "PREFIX core: <https://w3id.org/urdfkb/core#> SELECT ?c WHERE { ?c a/rdfs:subClassOf* core:Camera } ORDER BY ?c"]


def robot(server, name):
    status, _, out = http("GET", f"{server.base}/robots/{name}")
    return json.loads(out) if status == 200 else None


def test_kill_9_inside_the_store_transaction(shared, tmp_path):
    store, marker = tmp_path / "kb.sqlite3", tmp_path / "in-transaction"
    pr2, panda = shared / "urdf" / "pr2.urdf", shared / "urdf" / "panda.urdf"

    s = Server(store, marker, hang_on="doomed")
    assert s.wait(s.populate(pr2))["state"] == "succeeded"
    assert s.wait(s.populate(panda))["state"] == "succeeded"
    s.crash_during(panda, "?name=doomed")  # a new robot, killed half-written

    s = Server(store, marker, hang_on="pr2")
    assert [r["name"] for r in json.loads(http("GET", s.base + "/robots")[2])] == ["panda", "pr2"]
    s.crash_during(pr2, "?structure_only=true")  # replacing pr2: old destroyed, new written, not committed

    s = Server(store, marker)
    try:
        assert [r["name"] for r in json.loads(http("GET", s.base + "/robots")[2])] == ["panda", "pr2"]
        assert len(robot(s, "pr2")["components"]) == len(PR2.components)  # the old pr2, whole
        assert robot(s, "doomed") is None
        q = "ASK { ?s ?p ?o FILTER(STRSTARTS(STR(?s), 'https://w3id.org/urdfkb/robot/doomed#')) }"
        status, _, out = http("GET", f"{s.base}/sparql?" + urllib.parse.urlencode({"query": q}))
        assert status == 200 and json.loads(out)["boolean"] is False  # not a triple of the half-written robot
        assert s.wait(s.populate(panda, "?name=doomed"))["state"] == "succeeded"  # and the store still writes
    finally:
        s.kill()


def test_kill_9_inside_an_update_and_during_a_burst_of_readers(shared, tmp_path):
    store, marker = tmp_path / "kb.sqlite3", tmp_path / "in-transaction"
    s = Server(store, marker, hang_on=PR2_GRAPH)
    assert s.wait(s.populate(shared / "urdf" / "pr2.urdf"))["state"] == "succeeded"
    assert s.update("INSERT DATA { <urn:a> <urn:says> 'note one' . GRAPH <urn:mine> { <urn:b> <urn:says> 'note two' } }") == 204
    before = s.answers()
    # an update writing the default graph and PR2's graph, killed after PR2's graph was written
    s.crash_during(None, f"INSERT DATA {{ <urn:c> <urn:says> 'note three' . GRAPH <{PR2_GRAPH}> {{ <urn:d> <urn:says> 'note four' }} }}")

    s = Server(store, marker)
    try:
        assert s.answers() == before  # all or nothing: none of the killed update, all of the earlier one
        stop, statuses, end = threading.Event(), [], time.monotonic() + 60

        def reader():
            while not stop.is_set() and time.monotonic() < end:
                try:
                    statuses.append(http("GET", f"{s.base}/sparql?" + urllib.parse.urlencode({"query": ANSWERS[0]}), timeout=5)[0])
                except (OSError, HTTPException):  # the kill may cut a response short
                    return

        readers = [threading.Thread(target=reader) for _ in range(8)]
        for t in readers:
            t.start()
        for _ in range(600):  # until the burst is under way (however loaded the machine), then kill
            if len(statuses) >= 8:
                break
            time.sleep(0.05)
        s.kill()
        stop.set()
        for t in readers:
            t.join(10)
        assert statuses and set(statuses) == {200}
    finally:
        if s.proc.poll() is None:
            s.kill()
    s = Server(store, marker)
    try:
        assert s.answers() == before
        assert s.update("INSERT DATA { <urn:e> <urn:says> 'note five' }") == 204  # and the store still writes
    finally:
        s.kill()
