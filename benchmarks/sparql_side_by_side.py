"""Every bundled query over HTTP: a fresh `urdfkb serve` against a fresh `oxigraph serve`, same triples, 1 and 8 clients.

Both servers hold the same triples: N renamed copies of a populated PR2 (benchmarks/pr2_copies.py;
default 100), each its own graph, and the core ontology as background. Oxigraph gets them by `INSERT DATA`
(the core as urdfkb's index holds it); urdfkb's store file is written with them as such updates leave
them (pr2_copies.store_file), before it starts. Each bundled query, bound for the middle copy, is
sent as a form POST asking for SPARQL results JSON, `--requests` times (default 400) by 1 and by 8
keep-alive clients; the two servers take turns run by run (A/B interleaved, the order alternating),
`--rounds` times. Printed per query: the median over rounds of the one-client p50 latency and of the
throughput with 1 and 8 clients, for each server, and the ratios urdfkb/Oxigraph and 8 clients/1.
Both servers' answers are checked to hold the same rows first. urdfkb keeps answers in its result cache
(kb_server/result_cache.py), so after the first request of a run each is answered from there; with
`--result-cache 0` it starts with none, and every request goes to a query worker.

    URDFKB_SHARED=/work/shared .venv/bin/python -m benchmarks.sparql_side_by_side [--copies 100]
        [--requests 400] [--rounds 3] [--queries camera_frames sensors ...] [--result-cache MIB]
        [--client-processes]
"""
from __future__ import annotations

import argparse
import http.client
import json
import multiprocessing
import os
import queue
import statistics
import subprocess
import sys
import tempfile
import threading
import time
import urllib.parse
from pathlib import Path
from typing import Any

from benchmarks.pr2_copies import bound_queries, insert_data, pr2_graphs, renamed, store_file
from tests.kb_fixtures import free_port
from urdfkb.pipeline.knowledge.namespaces import CORE_GRAPH

TOKEN = "bench-token"
REPO = Path(__file__).resolve().parents[1]
BIN = Path(sys.executable).parent
JSON_RESULTS = "application/sparql-results+json"


def post(port: int, path: str, body: bytes, headers: dict, timeout: float = 600) -> bytes:
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=timeout)
    conn.request("POST", path, body, headers)
    r = conn.getresponse()
    data = r.read()
    conn.close()
    if r.status >= 300:
        raise RuntimeError(f"POST {path} on port {port}: {r.status} {data[:300]!r}")
    return data


def ready(port: int, path: str) -> None:
    """Wait (up to 5 minutes: a busy machine, 100 graphs to load) for a server to answer `path`."""
    for _ in range(3000):
        try:
            c = http.client.HTTPConnection("127.0.0.1", port, timeout=5)
            c.request("GET", path)
            if c.getresponse().status < 500:
                return
        except OSError:
            time.sleep(0.1)
    raise RuntimeError(f"no server on port {port}")


class Server:
    """One server process and how to query and update it."""

    def __init__(self, name: str, cmd: list[str], port: int, query_path: str, update_path: str, headers: dict):
        self.name, self.port, self.query_path, self.update_path = name, port, query_path, update_path
        self.update_headers = {"Content-Type": "application/sparql-update", **headers}
        env = {**os.environ, "PYTHONPATH": str(REPO)}  # this checkout's urdfkb
        self.proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env)

    def update(self, text: bytes) -> None:
        post(self.port, self.update_path, text, self.update_headers)

    def stop(self) -> None:
        self.proc.terminate()
        self.proc.wait(10)


def urdfkb_server(store: Path, port: int, *options: str) -> Server:
    """`urdfkb serve` (this checkout's) on `store`, with its defaults but `options`, once its query workers answer."""
    kb = Server("urdfkb", [sys.executable, "-m", "urdfkb", "serve", "--store", str(store), "--port", str(port),
                           "--token", TOKEN, *options], port, "/sparql", "/sparql", {"Authorization": f"Bearer {TOKEN}"})
    try:
        ready(port, "/robots")
        for _ in range(60):  # a worker loading its replica on a busy machine may take longer than a query's timeout
            try:
                rows(kb, "SELECT * WHERE {} LIMIT 1")
                return kb
            except RuntimeError:
                time.sleep(1)
        raise RuntimeError("urdfkb's query workers never answered")
    except BaseException:
        kb.stop()
        raise


def query_body(text: str) -> bytes:
    return urllib.parse.urlencode({"query": text}).encode()


def rows(server: Server, text: str) -> list[str]:
    """The answer's rows, each value's space-separated words sorted (GROUP_CONCAT joins in no set order)."""
    doc = json.loads(post(server.port, server.query_path, query_body(text),
                          {"Content-Type": "application/x-www-form-urlencoded", "Accept": JSON_RESULTS}))
    return sorted(json.dumps({v: {**t, "value": " ".join(sorted(t["value"].split(" ")))} for v, t in b.items()},
                             sort_keys=True) for b in doc["results"]["bindings"])


def _send(conn: http.client.HTTPConnection, server: Server, body: bytes, headers: dict) -> float:
    t = time.perf_counter()
    conn.request("POST", server.query_path, body, headers)
    r = conn.getresponse()
    r.read()
    if r.status != 200:
        raise RuntimeError(f"{server.name}: {r.status}")
    return time.perf_counter() - t


def _client(server: Server, body: bytes, headers: dict, per: int, start, out) -> None:
    """One client: a keep-alive connection, warmed, then `per` requests from the `start` barrier on; puts
    (latencies, its first request's start, its last answer's end) in `out` (perf_counter is one clock for all
    processes of the machine)."""
    conn = http.client.HTTPConnection("127.0.0.1", server.port, timeout=60)
    _send(conn, server, body, headers)  # connect, warm
    start.wait()
    t0 = time.perf_counter()
    mine = [_send(conn, server, body, headers) for _ in range(per)]
    out.put((mine, t0, time.perf_counter()))
    conn.close()


def measure(server: Server, body: bytes, clients: int, requests: int, extra: dict | None = None,
            processes: bool = False) -> tuple[float, float]:
    """(p50 ms, queries/s): `requests` form POSTs (with the `extra` headers) shared by `clients` keep-alive connections
    started together, each a thread of this process or (`processes`) a process of its own. Threads share this
    process's interpreter lock: with a server answering in 0.3 ms, eight Python client threads take most of a core
    (0.34 ms of CPU per request) and bound the figure; processes measure the server."""
    headers = {"Content-Type": "application/x-www-form-urlencoded", "Accept": JSON_RESULTS, **(extra or {})}
    per = requests // clients
    start: Any
    out: Any
    procs: list[Any]
    if processes:
        ctx = multiprocessing.get_context("fork")
        start, out = ctx.Barrier(clients), ctx.Queue()
        procs = [ctx.Process(target=_client, args=(server, body, headers, per, start, out)) for _ in range(clients)]
    else:
        start, out = threading.Barrier(clients), queue.Queue()
        procs = [threading.Thread(target=_client, args=(server, body, headers, per, start, out)) for _ in range(clients)]
    for p in procs:
        p.start()
    done = [out.get(timeout=600) for _ in procs]
    for p in procs:
        p.join()
    samples = [s for mine, _, _ in done for s in mine]
    elapsed = max(end for _, _, end in done) - min(t0 for _, t0, _ in done)
    return 1000 * statistics.median(samples), len(samples) / elapsed


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--copies", type=int, default=100)
    ap.add_argument("--requests", type=int, default=400)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--queries", nargs="*", help="bundled query names (default: all)")
    ap.add_argument("--client-processes", action="store_true", help="each client a process of its own (default: a "
                    "thread of this process; eight threads share its interpreter lock)")
    ap.add_argument("--result-cache", type=int, metavar="MIB", help="urdfkb's result cache (default: its own default; "
                    "0: none, every request evaluated by a worker)")
    args = ap.parse_args()
    options = () if args.result_cache is None else ("--result-cache", str(args.result_cache))
    core, pr2 = pr2_graphs()
    queries = bound_queries(args.copies // 2, args.queries)
    copies = dict(renamed(pr2, i) for i in range(args.copies))
    with tempfile.TemporaryDirectory() as tmp:
        store_file(Path(tmp) / "kb.sqlite3", copies)
        kport, oport = free_port(), free_port()
        kb = urdfkb_server(Path(tmp) / "kb.sqlite3", kport, *options)
        oxi = Server("oxigraph", [str(BIN / "oxigraph"), "serve", "--union-default-graph", "--bind",
                                  f"127.0.0.1:{oport}"], oport, "/query", "/update", {})
        try:
            ready(oport, "/")
            oxi.update(insert_data(CORE_GRAPH, core))
            for graph, data in copies.items():
                oxi.update(insert_data(graph, data))
            print(f"# {args.copies} PR2 copies ({len(pr2) // 1024} KiB of N-Triples each) in both", file=sys.stderr)
            for name, text in queries.items():
                a, b = rows(kb, text), rows(oxi, text)
                if a != b:
                    sys.exit(f"{name}: the servers' rows differ: {sorted(set(a) ^ set(b))[:4]}")
                print(f"# {name}: {len(a)} rows from both", file=sys.stderr)
            figures: dict[tuple[str, str, int], list[tuple[float, float]]] = {}
            for name, text in queries.items():
                body = query_body(text)
                for clients in (1, 8):
                    for r in range(args.rounds):
                        for server in (kb, oxi) if r % 2 == 0 else (oxi, kb):
                            figures.setdefault((name, server.name, clients), []).append(
                                measure(server, body, clients, args.requests,
                                        processes=args.client_processes))
        finally:
            kb.stop()
            oxi.stop()
    med = {k: (statistics.median(p for p, _ in v), statistics.median(q for _, q in v)) for k, v in figures.items()}
    cache = "urdfkb's default" if args.result_cache is None else f"{args.result_cache} MiB"
    print(f"{args.copies} PR2 copies, {args.requests} form POSTs per run, medians of {args.rounds} runs "
          f"interleaved; p50 with 1 client, throughput (q/s) with 1 and 8 clients; result cache: {cache}")
    print(f"{'query':<18} | {'urdfkb p50':>10} {'q/s 1c':>7} {'q/s 8c':>7} {'8c/1c':>6} | "
          f"{'oxi p50':>8} {'q/s 1c':>7} {'q/s 8c':>7} | {'kb/oxi 1c':>9} {'kb/oxi 8c':>9}")
    for name in queries:
        k1, k8, o1, o8 = (med[(name, s, c)] for s, c in (("urdfkb", 1), ("urdfkb", 8), ("oxigraph", 1), ("oxigraph", 8)))
        print(f"{name:<18} | {k1[0]:>8.2f}ms {k1[1]:>7.0f} {k8[1]:>7.0f} {k8[1] / k1[1]:>5.2f}x | "
              f"{o1[0]:>6.2f}ms {o1[1]:>7.0f} {o8[1]:>7.0f} | {k1[1] / o1[1]:>8.2f}x {k8[1] / o8[1]:>8.2f}x")


if __name__ == "__main__":
    main()
