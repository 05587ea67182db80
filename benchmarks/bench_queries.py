"""HRI query latency/throughput: the KB store (as served: native SQL, else rdflib), rdflib alone, pyoxigraph.

Stores hold 1, 10 and 100 robots populated from the shared URDFs (distinct names; PR2 with the
hand-written test abstraction, the others with keyword-made abstractions). pyoxigraph holds the
same triples (each robot's self-contained export, in its default graph). Then, on the largest
store: the same queries over HTTP (waitress; 1 and 8 concurrent clients), and the KB's latency
while another thread re-populates a robot continuously (store-lock contention).

    .venv/bin/python benchmarks/bench_queries.py [--sizes 1,10,100] [--iterations 40]
"""
from __future__ import annotations

import argparse
import logging
import statistics
import sys
import tempfile
import threading
import time
import urllib.parse
import urllib.request
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pyoxigraph

REPO = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(REPO), str(REPO / "tests")]

from kb_fixtures import PR2, live, make_app  # noqa: E402
from kb_server.queries import load_queries  # noqa: E402
from kb_server.store import Store  # noqa: E402
from pipeline.components import END_EFFECTOR, SENSOR, Abstraction, Component, SubComponent  # noqa: E402
from pipeline.ingest import load_urdf  # noqa: E402

SHARED = REPO.parent / "shared" / "urdf"
QUERIES = {"cameras": {}, "sensors": {}, "mounted_below": {"link": "base_link"}, "end_effectors": {},
           "low_confidence": {"threshold": "0.5"}}
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


def build(n: int, trees: dict, tmp: Path) -> tuple[Store, pyoxigraph.Store, list[str]]:
    store = Store(tmp / f"kb{n}.sqlite3")
    oxi = pyoxigraph.Store()
    names = list(trees)
    robots = []
    for i in range(n):
        urdf = names[i % len(names)]
        name = f"{urdf}_{i}"
        tree = trees[urdf]
        store.replace_robot(name, tree, PR2 if urdf == "pr2" else keyword_abstraction(tree))
        robots.append(name)
        data = store.graph(name).serialize(format="nt", encoding="utf-8")
        oxi.bulk_load(data, pyoxigraph.RdfFormat.N_TRIPLES)
    return store, oxi, robots


def stats(samples: list[float]) -> tuple[float, float, float]:
    """p50 ms, p99 ms, queries/s."""
    s = sorted(samples)
    return 1000 * statistics.median(s), 1000 * s[min(len(s) - 1, int(0.99 * len(s)))], len(s) / sum(s)


def timed(fn, iterations: int) -> list[float]:
    for _ in range(3):
        fn()
    out = []
    for _ in range(iterations):
        t = time.perf_counter()
        fn()
        out.append(time.perf_counter() - t)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="1,10,100")
    ap.add_argument("--iterations", type=int, default=40)
    args = ap.parse_args()
    trees = {p.stem: load_urdf(p) for p in sorted(SHARED.glob("*.urdf"))}
    trees = {"pr2": trees.pop("pr2"), **trees}  # robot 0 is always PR2: the one queried
    named = load_queries()
    rows, busy_rows = [], []
    with tempfile.TemporaryDirectory() as tmp:
        for n in (int(x) for x in args.sizes.split(",")):
            t0 = time.perf_counter()
            store, oxi, robots = build(n, trees, Path(tmp))
            print(f"# {n} robots populated in {time.perf_counter() - t0:.1f} s", file=sys.stderr)
            target = store.robot(robots[0]).robot_iri
            for qname, params in QUERIES.items():
                text = named[qname].bind(target, params)
                kb_rows = store.query(text).rows
                ox_rows = list(oxi.query(text))
                assert len(kb_rows) == len(ox_rows), (qname, len(kb_rows), len(ox_rows))
                engine = store.query(text).engine
                kb = stats(timed(lambda: store.query(text), args.iterations))
                rdf = stats(timed(lambda: store.query(text, engine="rdflib"), max(5, args.iterations // 4)))
                ox = stats(timed(lambda: list(oxi.query(text)), args.iterations))
                rows.append((n, qname, engine, len(kb_rows), *kb, rdf[0], *ox, kb[0] / ox[0]))
            if n == max(int(x) for x in args.sizes.split(",")):
                http_rows = over_http(store, robots[0], args.iterations)
                busy_rows = under_populate(store, trees["pr2"], target, named, args.iterations)
            store.close()
    print(f"{'robots':>6} {'query':<15} {'engine':<9} {'rows':>4} | {'KB p50':>8} {'p99':>8} {'q/s':>7} |"
          f" {'rdflib p50':>10} | {'oxi p50':>8} {'p99':>8} {'q/s':>7} | {'KB/oxi':>6}")
    for n, q, engine, nrows, kp50, kp99, kqps, rp50, op50, op99, oqps, ratio in rows:
        print(f"{n:>6} {q:<15} {engine:<9} {nrows:>4} | {kp50:>6.2f}ms {kp99:>6.2f}ms {kqps:>7.0f} |"
              f" {rp50:>8.1f}ms | {op50:>6.3f}ms {op99:>6.3f}ms {oqps:>7.0f} | {ratio:>5.1f}x")
    print("\nOver HTTP (waitress, GET /queries/<name>, largest store): 1 client, then 8 concurrent clients:")
    print(f"{'query':<15} | {'p50':>8} {'p99':>8} {'q/s':>6} | {'8c p50':>8} {'p99':>8} {'q/s':>6}")
    for q, one, many in http_rows:
        print(f"{q:<15} | {one[0]:>6.2f}ms {one[1]:>6.2f}ms {one[2]:>6.0f} | {many[0]:>6.2f}ms {many[1]:>6.2f}ms {many[2]:>6.0f}")
    print("\nKB latency while another thread re-populates PR2 continuously (largest store):")
    print(f"{'query':<15} | {'idle p50':>9} {'p99':>8} | {'busy p50':>9} {'p99':>8} | {'p50 x':>6} | populates")
    for q, idle, busy, pops in busy_rows:
        print(f"{q:<15} | {idle[0]:>7.2f}ms {idle[1]:>6.2f}ms | {busy[0]:>7.2f}ms {busy[1]:>6.2f}ms |"
              f" {busy[0] / idle[0]:>5.1f}x | {pops}")


def over_http(store: Store, robot: str, iterations: int) -> list:
    """Per query: (p50, p99, q/s) with one client, and with 8 concurrent clients (aggregate q/s)."""
    app, jobs = make_app(store)
    logging.getLogger("waitress.queue").setLevel(logging.ERROR)  # 8 clients > 6 threads: expected
    out = []
    with live(app) as base:
        for qname, params in QUERIES.items():
            url = f"{base}/queries/{qname}?" + urllib.parse.urlencode({"robot": robot, **params})

            def get():
                with urllib.request.urlopen(url) as r:
                    r.read()

            one = stats(timed(get, iterations))
            with ThreadPoolExecutor(8) as pool:
                t0 = time.perf_counter()
                samples = [x for xs in pool.map(lambda _: timed(get, iterations), range(8)) for x in xs]
                wall = time.perf_counter() - t0
            p50, p99, _ = stats(samples)
            out.append((qname, one, (p50, p99, len(samples) / wall)))
    jobs.shutdown()
    return out


def under_populate(store: Store, tree, target: str, named, iterations: int) -> list:
    out = []
    for qname, params in QUERIES.items():
        text = named[qname].bind(target, params)
        idle = stats(timed(lambda: store.query(text), iterations))
        stop, pops = threading.Event(), [0]

        def writer():
            while not stop.is_set():
                store.replace_robot("busy", tree, PR2)
                pops[0] += 1

        thread = threading.Thread(target=writer)
        thread.start()
        try:
            busy = stats(timed(lambda: store.query(text), iterations))
        finally:
            stop.set()
            thread.join()
        out.append((qname, idle, busy, pops[0]))
    return out


if __name__ == "__main__":
    main()
