"""Where a SPARQL request's time goes, stage by stage, for a cheap query (sensors) and for camera_frames.

The data are N renamed copies of a populated PR2 (benchmarks/pr2_copies.py; default 100). Each stage is
timed on its own in this process, `--repeat` times (median), as the server runs it for one form POST
asking for SPARQL results JSON:

- HTTP parsing: waitress's parser reading the request's bytes;
- request checks and form: kb_server.sparql_front reading the parsed request (Host and cross-site checks, the
  form's fields), which `urdfkb serve` does instead of handing it to Flask (Flask's own handling of the same
  request, its store answering at once, is printed below for comparison: it is not on the path);
- query checks: kb_server.sparql.scan (the lexical pass refusing SERVICE, LOAD, deep nesting);
- hand-off to the worker: a query worker's round trip (kb_server.index, waited for by this thread: one thread
  wake-up more than the server's, whose answering thread writes the answer) less what the worker does inside it
  (the checks, evaluation and serialisation, timed in this process on the same data);
- execution: Oxigraph evaluating the query, every solution read;
- serialisation: the answer written as SPARQL results JSON (within the result limits), less execution;
- end to end: the p50 of the same request over HTTP to a `urdfkb serve` in its own process holding the same
  graphs, one keep-alive client, sent with `Cache-Control: no-cache` so that a worker evaluates it; "the rest"
  is what it holds beyond the stages above (waitress's loop, socket reads and writes, writing the answer, the
  client).

Then the path of an answer the result cache holds (kb_server/result_cache.py): the lookup (the query's key and
the cache's entry), and the p50 of the same request over HTTP without no-cache, answered from the cache by the
I/O thread that read it.

    URDFKB_SHARED=/work/shared .venv/bin/python -m benchmarks.sparql_breakdown [--copies 100] [--repeat 300]
"""
from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import pyoxigraph as ox
from waitress.adjustments import Adjustments
from waitress.parser import HTTPRequestParser

from benchmarks.pr2_copies import bound_queries, pr2_graphs, renamed, store_file
from benchmarks.sparql_side_by_side import JSON_RESULTS, measure, query_body, urdfkb_server
from tests.kb_fixtures import free_port, make_app
from urdfkb.kb_server.index import Index
from urdfkb.kb_server.result_cache import ResultCache, cache_key
from urdfkb.kb_server.results import ResultLimits, serialize
from urdfkb.kb_server.services import EXTENSION
from urdfkb.kb_server.sparql_front import SparqlFront
from urdfkb.kb_server.sparql import Result, run_query, scan
from urdfkb.kb_server.store import Store
from urdfkb.pipeline.knowledge.namespaces import CORE_GRAPH
from urdfkb.settings import RESULT_CACHE

QUERIES = ("sensors", "camera_frames")


def median_ms(f: Callable[[], object], repeat: int) -> float:
    f()
    samples = []
    for _ in range(repeat):
        t = time.perf_counter()
        f()
        samples.append(time.perf_counter() - t)
    return 1000 * statistics.median(samples)


def raw_request(body: bytes, port: int = 8000) -> bytes:
    return (f"POST /sparql HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nContent-Type: application/x-www-form-urlencoded\r\n"
            f"Accept: {JSON_RESULTS}\r\nContent-Length: {len(body)}\r\n\r\n").encode() + body


def http_parse(raw: bytes) -> HTTPRequestParser:
    parser, data = HTTPRequestParser(Adjustments()), raw
    while data and not parser.completed:
        data = data[parser.received(data):]
    return parser


def flask_app(app, body: bytes) -> Callable[[], None]:
    from werkzeug.test import EnvironBuilder

    builder = EnvironBuilder(path="/sparql", method="POST", data=body, headers=[
        ("Host", "127.0.0.1"), ("Content-Type", "application/x-www-form-urlencoded"), ("Accept", JSON_RESULTS)])

    def call() -> None:
        out = app(builder.get_environ(), lambda status, headers, exc=None: None)
        b"".join(out)
        getattr(out, "close", lambda: None)()
    return call


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--copies", type=int, default=100)
    ap.add_argument("--repeat", type=int, default=300)
    args = ap.parse_args()
    core, pr2 = pr2_graphs()
    copies = dict(renamed(pr2, i) for i in range(args.copies))
    queries = bound_queries(args.copies // 2, list(QUERIES))
    limits = ResultLimits()
    index = Index({CORE_GRAPH: core, **copies}, 1, limits, cache_bytes=0)  # every query to its worker
    rows: dict[str, dict[str, float]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        stub = Store(Path(tmp) / "stub.sqlite3", workers=0)
        app, jobs = make_app(stub)
        front = SparqlFront(app.extensions[EXTENSION], 0, "waitress")
        store_file(Path(tmp) / "kb.sqlite3", copies)
        kb = urdfkb_server(Path(tmp) / "kb.sqlite3", free_port())
        try:
            for name in QUERIES:
                text, body = queries[name], query_body(queries[name])
                answer = index.query(text, JSON_RESULTS, 10)
                stub.query = lambda *a, **k: answer  # type: ignore[method-assign]  # the app's store answers at once
                master = index.master

                def execute() -> None:
                    for _ in master.query(text, use_default_graph_as_union=True):  # type: ignore[union-attr]  # a SELECT
                        pass

                def evaluate_and_write() -> None:
                    serialize(master.query(text, use_default_graph_as_union=True), ox.QueryResultsFormat.JSON, limits)

                r = args.repeat
                parsed = http_parse(raw_request(body))
                stage = {
                    "HTTP parsing": median_ms(lambda: http_parse(raw_request(body)), r),
                    "request checks and form": median_ms(lambda: front.query(parsed), r),
                    "query checks (scan)": median_ms(lambda: scan(text), r),
                    "execution": median_ms(execute, r),
                }
                stage["serialisation"] = max(median_ms(evaluate_and_write, r) - stage["execution"], 0.0)
                in_worker = median_ms(lambda: run_query(master, text, JSON_RESULTS, limits=limits), r)
                stage["hand-off to the worker"] = max(median_ms(lambda: index.query(text, JSON_RESULTS, 10), r)
                                                      - in_worker, 0.0)
                end_to_end = measure(kb, body, 1, r, {"Cache-Control": "no-cache"})[0]
                stage["the rest (loop, sockets, client)"] = end_to_end - sum(stage.values())
                stage["end to end (HTTP p50)"] = end_to_end
                stage["(not on the path: Flask answering it)"] = median_ms(flask_app(app, body), r)
                cache, k = ResultCache(RESULT_CACHE), cache_key(text, JSON_RESULTS, None, None)
                assert k is not None
                cache.put(k, cache.generation, answer)

                def lookup() -> Result | None:  # as Index.cached
                    found = cache_key(text, JSON_RESULTS, None, None)
                    return cache.get(found) if found else None
                stage["result cache: lookup"] = median_ms(lookup, r)
                stage["result cache: end to end (HTTP p50)"] = measure(kb, body, 1, r)[0]
                rows[name] = stage
        finally:
            kb.stop()
            jobs.shutdown()
            stub.close()
            index.close()
    print(f"{args.copies} PR2 copies; median ms of {args.repeat} runs per stage (form POST, SPARQL results JSON)")
    print(f"{'stage':<40}" + "".join(f"{q:>15}" for q in QUERIES))
    for label in rows[QUERIES[0]]:
        print(f"{label:<40}" + "".join(f"{rows[q][label]:>15.3f}" for q in QUERIES))


if __name__ == "__main__":
    main()
