"""Resource limits: bounded query answers.

Each case answered badly before: a 536 MB answer built in full."""
import functools
import json
import random
import time
import urllib.parse

import pyoxigraph as ox
import pytest

from kb_fixtures import PR2, fake_runner, http, make_app, running
from urdfkb.kb_server import queries
from urdfkb.kb_server.cli import main
from urdfkb.kb_server.results import ResultLimits, ResultTooLarge, serialize
from urdfkb.kb_server.serve import make_server
from urdfkb.kb_server.store import Store
from urdfkb.pipeline.errors import UrdfkbError
from urdfkb.pipeline.ingest import load_urdf

CROSS = "SELECT * { ?a ?p ?b . ?c ?q ?d } LIMIT 1200000"  # 536 MB of JSON over PR2 before the limits


@pytest.fixture(scope="module")
def pr2_store(shared, tmp_path_factory):
    path = tmp_path_factory.mktemp("kb") / "kb.sqlite3"
    store = Store(path, workers=0)
    store.replace_robot("pr2", load_urdf(shared / "urdf" / "pr2.urdf"), PR2)
    store.close()
    return path


@pytest.fixture(scope="module")
def server(pr2_store):
    """A live `urdfkb serve` (make_server, default options) over the PR2 store; yields its base URL."""
    srv, store, jobs = make_server(pr2_store, port=0, runner=fake_runner())
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


def test_named_queries_and_the_cli_answer_within_the_same_limits(pr2_store, monkeypatch, capsys):
    store = Store(pr2_store, limits=ResultLimits(rows=3))
    app, jobs = make_app(store)
    try:
        r = app.test_client().get("/queries/components?robot=pr2")
        assert r.status_code == 413 and b"more than 3 rows" in r.data
    finally:
        jobs.shutdown()
        store.close()
    monkeypatch.setattr(queries, "Store", functools.partial(Store, limits=ResultLimits(rows=3)))
    assert main(["query", "components", "--robot", "pr2", "--store", str(pr2_store)]) == 2
    assert "urdfkb: error: the answer has more than 3 rows" in capsys.readouterr().err


def test_limits_must_be_positive():
    for bad in (dict(rows=0), dict(bytes=-1)):
        with pytest.raises(UrdfkbError, match="must be positive"):
            ResultLimits(**bad)
