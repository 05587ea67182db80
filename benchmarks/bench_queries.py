"""HRI queries over HTTP: urdfkb serve vs `oxigraph serve` holding the same triples, 1 and 8 clients.

The urdfkb store holds N robots (default 100) populated from the shared URDFs (distinct names;
PR2 with the hand-written test abstraction, the others with keyword-made abstractions). Oxigraph
(`oxigraph serve --union-default-graph`, the same default-graph semantics) is loaded with the very
graphs urdfkb's index holds (N-Quads). Both run as their own server processes (`urdfkb serve`
with its defaults) and get the same query text (POST
application/sparql-query, keep-alive connections); printed: p50 latency with one client and
throughput with 1 and 8 concurrent clients, side by side.

    .venv/bin/python -m benchmarks.bench_queries [--robots 100] [--seconds 3]
"""
from __future__ import annotations

import argparse
import http.client
import io
import statistics
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pyoxigraph

from tests.kb_fixtures import PR2, free_port
from urdfkb.kb_server.queries import load_queries
from urdfkb.kb_server.store import Store
from urdfkb.pipeline.abstraction.components import END_EFFECTOR, SENSOR, Abstraction, Component, SubComponent
from urdfkb.pipeline.reading.ingest import load_urdf

REPO = Path(__file__).resolve().parents[1]
SHARED = REPO.parent / "shared" / "urdf"
QUERIES = {"cameras": {}, "sensors": {}, "mounted_below": {"link": "base_link"}, "end_effectors": {},
           "low_confidence": {}, "components": {}}
KEYWORDS = (("optical", SENSOR, "MonocularCamera", "RgbFrame"), ("camera", SENSOR, "MonocularCamera", "RgbFrame"),
            ("laser", SENSOR, "Lidar", "SensingElement"), ("imu", SENSOR, "IMU", "SensingElement"),
            ("tool", END_EFFECTOR, "Gripper", "ToolCenterPoint"), ("finger", END_EFFECTOR, "Gripper", "ContactSurface"))


def keyword_abstraction(tree) -> Abstraction:
    """One component per link whose name has a keyword (confidence varies, so some need review)."""
    parent = {e.child: e.parent for e in tree.edges}
    comps = []
    for i, link in enumerate(tree.links):
        for word, kind, cls, sub in KEYWORDS:
            if word in link.lower() and link in parent:
                comps.append(Component(f"c{i}", kind, cls, round(0.3 + (i % 7) / 10, 2), parent[link],
                                       (SubComponent(link, sub, 0.8),)))
                break
    return Abstraction(tuple(comps))


def populate(store, n: int, trees: dict) -> list[str]:
    names, robots = list(trees), []
    for i in range(n):
        urdf = names[i % len(names)]
        name = f"{urdf}_{i}"
        store.replace_robot(name, trees[urdf], PR2 if urdf == "pr2" else keyword_abstraction(trees[urdf]))
        robots.append(name)
    return robots


class Client:
    """One keep-alive HTTP connection posting queries to `path`."""

    def __init__(self, port: int, path: str):
        self.conn, self.path = http.client.HTTPConnection("127.0.0.1", port), path

    def __call__(self, text: str) -> bytes:
        self.conn.request("POST", self.path, text.encode(), {"Content-Type": "application/sparql-query",
                                                             "Accept": "application/sparql-results+json"})
        r = self.conn.getresponse()
        body = r.read()
        assert r.status == 200, body[:300]
        return body


def measure(port: int, path: str, text: str, clients: int, seconds: float) -> tuple[float, float]:
    """(p50 ms, queries/s) with `clients` concurrent clients for about `seconds`."""
    def run(_):
        c, out = Client(port, path), []
        for _ in range(5):
            c(text)
        end = time.perf_counter() + seconds
        while time.perf_counter() < end:
            t = time.perf_counter()
            c(text)
            out.append(time.perf_counter() - t)
        return out

    t0 = time.perf_counter()
    with ThreadPoolExecutor(clients) as pool:
        samples = [x for xs in pool.map(run, range(clients)) for x in xs]
    return 1000 * statistics.median(samples), len(samples) / (time.perf_counter() - t0)


def _ready(port: int, path: str, body: bytes | None = None) -> None:
    """Wait for a server to answer `path` (GET, or POST `body`) with a 2xx."""
    for _ in range(300):
        try:
            c = http.client.HTTPConnection("127.0.0.1", port)
            c.request("POST" if body else "GET", path, body, {"Content-Type": "application/n-quads"} if body else {})
            if c.getresponse().status < 300:
                return
        except OSError:
            time.sleep(0.1)
    raise RuntimeError(f"no server on port {port}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--robots", type=int, default=100)
    ap.add_argument("--seconds", type=float, default=3.0)
    args = ap.parse_args()
    trees = {p.stem: load_urdf(p) for p in sorted(SHARED.glob("*.urdf"))}
    trees = {"pr2": trees.pop("pr2"), **trees}  # robot 0 is always PR2: the one queried
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "kb.sqlite3"
        store = Store(path, workers=0)
        t0 = time.perf_counter()
        robots = populate(store, args.robots, trees)
        print(f"# {args.robots} robots populated in {time.perf_counter() - t0:.1f} s", file=sys.stderr)
        entry = store.robot(robots[0])
        assert entry is not None, f"{robots[0]} was not stored"
        target = entry.robot_iri
        store.close()
        t0 = time.perf_counter()
        store = Store(path, workers=0)
        print(f"# store reopened, index rebuilt from the quadstore, in {time.perf_counter() - t0:.1f} s", file=sys.stderr)
        dump = io.BytesIO()
        store.index.master.dump(dump, format=pyoxigraph.RdfFormat.N_QUADS)
        nquads = dump.getvalue()
        store.close()
        kport, oport = free_port(), free_port()
        bin_dir = Path(sys.executable).parent
        servers = [subprocess.Popen([str(bin_dir / "urdfkb"), "serve", "--store", str(path), "--port", str(kport)],
                                    stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL),
                   subprocess.Popen([str(bin_dir / "oxigraph"), "serve", "--union-default-graph", "--bind",
                                     f"127.0.0.1:{oport}"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)]
        try:
            _ready(kport, "/robots")
            _ready(oport, "/store", nquads)
            print(f"# {len(nquads) // 1024} KiB of N-Quads in both", file=sys.stderr)
            named, rows = load_queries(), []
            for qname, params in QUERIES.items():
                text = named[qname].bind(target, params)
                a = Client(kport, "/sparql")(text)
                b = Client(oport, "/query")(text)
                assert a.count(b"{") == b.count(b"{"), qname  # same number of terms in the answer
                kb1, kb8 = (measure(kport, "/sparql", text, c, args.seconds) for c in (1, 8))
                ox1, ox8 = (measure(oport, "/query", text, c, args.seconds) for c in (1, 8))
                rows.append((qname, kb1, kb8, ox1, ox8))
        finally:
            for proc in servers:
                proc.terminate()
                proc.wait(10)
    print(f"{args.robots} robots, HTTP, same query text; p50 with 1 client, throughput (q/s) with 1 and 8 clients")
    print(f"{'query':<15} | {'urdfkb p50':>10} {'q/s 1c':>7} {'q/s 8c':>7} {'8c/1c':>6} | "
          f"{'oxigraph p50':>12} {'q/s 1c':>7} {'q/s 8c':>7} | {'kb/oxi 8c':>9}")
    for q, kb1, kb8, ox1, ox8 in rows:
        print(f"{q:<15} | {kb1[0]:>8.2f}ms {kb1[1]:>7.0f} {kb8[1]:>7.0f} {kb8[1] / kb1[1]:>5.2f}x | "
              f"{ox1[0]:>10.2f}ms {ox1[1]:>7.0f} {ox8[1]:>7.0f} | {kb8[1] / ox8[1]:>8.2f}x")


if __name__ == "__main__":
    main()
