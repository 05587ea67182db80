"""kill -9 during a populate: after restart every earlier robot is intact and no half-written one exists.

The real server runs in a subprocess (SERVER below). Its test-only hook wraps build_robot so that,
for the robot named in URDFKB_TEST_HANG_ON, it touches a marker file and sleeps *inside* the store
lock and the open SQLite transaction (old robot destroyed, new one written, nothing committed);
the test then kills the process with SIGKILL.
"""
import json
import os
import signal
import subprocess
import sys
import time
import urllib.parse
from pathlib import Path

from kb_fixtures import PR2, free_port, http

REPO = Path(__file__).resolve().parents[1]
SERVER = """
import os, sys, time
sys.path[:0] = [{repo!r}, {tests!r}]
import kb_server.store as store_mod
from kb_fixtures import PR2, fake_runner
from kb_server.serve import make_server

real_build, hang_on, marker = store_mod.build_robot, os.environ.get("URDFKB_TEST_HANG_ON"), os.environ["URDFKB_TEST_MARKER"]

def build_then_hang(world, tree, name, *args, **kw):
    onto = real_build(world, tree, name, *args, **kw)
    if name == hang_on:
        open(marker, "w").close()
        time.sleep(3600)
    return onto

store_mod.build_robot = build_then_hang
server, store, jobs = make_server(sys.argv[1], port=int(sys.argv[2]), runner=fake_runner({{"pr2": PR2}}))
server.run()
""".format(repo=str(REPO), tests=str(REPO / "tests"))


class Server:
    def __init__(self, store: Path, marker: Path, hang_on: str = ""):
        self.port = free_port()
        self.base = f"http://127.0.0.1:{self.port}"
        self.marker = marker
        env = {**os.environ, "URDFKB_TEST_HANG_ON": hang_on, "URDFKB_TEST_MARKER": str(marker)}
        self.proc = subprocess.Popen([sys.executable, "-c", SERVER, str(store), str(self.port)], env=env)
        for _ in range(200):
            try:
                if http("GET", self.base + "/robots", timeout=1)[0] == 200:
                    return
            except OSError:
                time.sleep(0.1)
        self.kill()
        raise RuntimeError("server did not start")

    def populate(self, urdf: Path, query: str = "") -> str:
        status, _, out = http("POST", f"{self.base}/populate{query}", urdf.read_bytes(), {"Content-Type": "application/xml"})
        assert status == 202
        return json.loads(out)["id"]

    def wait(self, job_id: str) -> dict:
        return json.loads(http("GET", f"{self.base}/jobs/{job_id}?wait=1&timeout=60")[2])

    def kill(self) -> None:
        os.kill(self.proc.pid, signal.SIGKILL)
        self.proc.wait(10)

    def crash_during(self, urdf: Path, query: str) -> None:
        """Populate, wait until it is inside the store transaction, then kill -9."""
        self.populate(urdf, query)
        for _ in range(300):
            if self.marker.exists():
                break
            time.sleep(0.05)
        assert self.marker.exists(), "the populate never reached the store transaction"
        self.kill()
        self.marker.unlink()


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
