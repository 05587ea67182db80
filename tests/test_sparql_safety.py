"""The dataset SPARQL Update sees (robots are named graphs, the core is read-only) and hostile queries."""
import http.server
import json
import multiprocessing
import socket
import threading
import urllib.parse

import pyoxigraph as ox
import pytest

from tests.kb_fixtures import client, copied, make_app
from urdfkb.kb_server.results import ResultLimits
from urdfkb.kb_server.store import Store

TOKEN = "t0k"
CORE = "https://w3id.org/urdfkb/core#"
PR2_GRAPH = "https://w3id.org/urdfkb/robot/pr2#"
COUNT_CORE = f"SELECT (COUNT(*) AS ?n) WHERE {{ GRAPH <{CORE}> {{ ?s ?p ?o }} }}"


def _kb(pr2_kb, tmp_path, workers: int):
    store = Store(copied(pr2_kb, tmp_path), workers=workers)
    app, jobs = make_app(store, token=TOKEN, query_timeout=2.0)
    yield client(app), store
    jobs.shutdown()
    store.close()


@pytest.fixture
def kb(pr2_kb, tmp_path):
    """The app over a store holding PR2, answering SPARQL in this process."""
    yield from _kb(pr2_kb, tmp_path, workers=0)


@pytest.fixture
def kb_workers(pr2_kb, tmp_path):
    """The same with query worker processes, which alone enforce a deadline."""
    yield from _kb(pr2_kb, tmp_path, workers=2)


def ask(api, q):
    status, _, body = api("GET", "/sparql?" + urllib.parse.urlencode({"query": q}))
    assert status == 200, body
    doc = json.loads(body)
    return doc["boolean"] if "boolean" in doc else [{k: v["value"] for k, v in b.items()} for b in doc["results"]["bindings"]]


def update(api, text, token=TOKEN):
    return api("POST", "/sparql", text.encode(), {"Content-Type": "application/sparql-update", "Authorization": f"Bearer {token}"})


def test_graphs_listed_are_the_core_and_the_robots(kb):
    api, _ = kb
    assert sorted(r["g"] for r in ask(api, "SELECT DISTINCT ?g WHERE { GRAPH ?g { ?s ?p ?o } }")) == [CORE, PR2_GRAPH]


def test_the_core_is_read_only(kb):
    api, _ = kb
    core_size = ask(api, COUNT_CORE)[0]["n"]
    for text in (f"INSERT DATA {{ GRAPH <{CORE}> {{ <urn:a> <urn:b> <urn:c> }} }}", f"CLEAR GRAPH <{CORE}>",
                 f"DELETE WHERE {{ GRAPH <{CORE}> {{ ?s ?p ?o }} }}"):
        status, _, body = update(api, text)
        assert status == 403 and b"read-only" in body
    assert ask(api, COUNT_CORE)[0]["n"] == core_size


def test_clear_default_drop_all_and_clear_robot_keep_the_core(kb):
    api, store = kb
    core_size = ask(api, COUNT_CORE)[0]["n"]
    assert update(api, "INSERT DATA { <urn:note> <urn:says> 'hello' }")[0] == 204
    assert ask(api, "ASK { <urn:note> ?p ?o }") is True
    assert update(api, "CLEAR DEFAULT")[0] == 204
    assert ask(api, "ASK { <urn:note> ?p ?o }") is False
    assert ask(api, f"ASK {{ GRAPH <{PR2_GRAPH}> {{ ?s ?p ?o }} }}") is True  # robots are named graphs: untouched
    assert update(api, f"CLEAR GRAPH <{PR2_GRAPH}>")[0] == 204
    assert ask(api, f"ASK {{ GRAPH <{PR2_GRAPH}> {{ ?s ?p ?o }} }}") is False and store.robot("pr2") is None
    assert update(api, "INSERT DATA { GRAPH <urn:mine> { <urn:a> <urn:b> <urn:c> } }")[0] == 204
    assert update(api, "DROP ALL")[0] == 204
    assert ask(api, "ASK { GRAPH <urn:mine> { ?s ?p ?o } }") is False
    assert ask(api, COUNT_CORE)[0]["n"] == core_size  # DROP ALL drops every writable graph, never the core
    assert ask(api, "PREFIX rdfs: <http://www.w3.org/2000/01/rdf-schema#> "
                    f"ASK {{ <{CORE}RGBDCamera> rdfs:subClassOf* <{CORE}Camera> }}") is True


def test_updates_persist_exactly_across_restart(pr2_kb, tmp_path):
    path = copied(pr2_kb, tmp_path)
    s = Store(path, workers=0)
    s.update('INSERT DATA { <urn:x> <urn:v> "01"^^<http://www.w3.org/2001/XMLSchema#integer> . '
             'GRAPH <urn:g> { <urn:x> <urn:w> _:b } }')
    s.update(f"INSERT DATA {{ GRAPH <{PR2_GRAPH}> {{ <{PR2_GRAPH}comp_kinect> <urn:checked> true }} }}")
    queries = ["SELECT ?o WHERE { <urn:x> <urn:v> ?o }", "SELECT ?g WHERE { GRAPH ?g { <urn:x> <urn:w> [] } }",
               f"ASK {{ GRAPH <{PR2_GRAPH}> {{ ?c <urn:checked> true }} }}",
               "SELECT (COUNT(*) AS ?n) WHERE { ?s ?p ?o }"]
    before = [s.query(q).body for q in queries]
    s.close()
    s = Store(path, workers=0)
    assert [s.query(q).body for q in queries] == before
    assert b'"1"' in before[0] and b"true" in before[2]
    s.close()


def test_using_and_from_never_fetch(kb):
    api, _ = kb
    with socket.socket() as listener:  # a "remote" server that would see any fetch
        listener.bind(("127.0.0.1", 0))
        listener.listen(1)
        listener.settimeout(0.5)
        remote = f"http://127.0.0.1:{listener.getsockname()[1]}/data.ttl"
        assert update(api, f"INSERT {{ <urn:a> <urn:b> ?o }} USING <{remote}> WHERE {{ ?s ?p ?o }}")[0] == 204
        status, _, _ = api("GET", "/sparql?" + urllib.parse.urlencode({"query": f"SELECT * FROM <{remote}> {{ ?s ?p ?o }}"}))
        assert status == 400
        for text in (f"LOAD <{remote}>", f"INSERT {{ ?s ?p ?o }} WHERE {{ SERVICE <{remote}> {{ ?s ?p ?o }} }}"):
            assert update(api, text)[0] == 400
        with pytest.raises(socket.timeout):
            listener.accept()


def test_hostile_queries_are_answered_or_refused_cleanly(kb):
    api, _ = kb
    long_a = "a" * 5000
    regex = f'SELECT * WHERE {{ BIND("{long_a}" AS ?x) FILTER(REGEX(?x, "^(a+)+$")) }}'  # linear-time regex engine
    assert len(ask(api, regex)) == 1
    assert ask(api, 'SELECT * WHERE { BIND("a.b" AS ?x) FILTER(REGEX(?x, ".", "q")) }') == [{"x": "a.b"}]
    assert ask(api, "SELECT (COALESCE() AS ?x) WHERE {}") == [{}]
    for q in ('SELECT * WHERE { BIND("\\uD800" AS ?x) }', "SELECT * WHERE " + "{" * 50_000 + "}" * 50_000):
        status, ctype, body = api("POST", "/sparql", q.encode(), {"Content-Type": "application/sparql-query"})
        assert status == 400 and ctype.startswith("text/plain"), body[:200]


@pytest.mark.slow
def test_a_query_past_its_deadline_never_stalls_others(kb_workers):
    api, _ = kb_workers
    items = ",".join(f'"item{i}"' for i in range(100_000))  # ~1 MB, a 100k-item IN over every triple
    slow = f"SELECT * WHERE {{ ?s ?p ?o FILTER(?o IN ({items})) }}"
    result = {}

    def run_slow():
        result["slow"] = api("POST", "/sparql", slow.encode(), {"Content-Type": "application/sparql-query"})[0]

    t = threading.Thread(target=run_slow)
    t.start()
    answers = [ask(api, f"ASK {{ GRAPH <{PR2_GRAPH}> {{ ?s ?p ?o }} }}") for _ in range(20)]  # answered meanwhile
    t.join(30)
    assert answers == [True] * 20 and result["slow"] == 503
    assert ask(api, "ASK { ?s ?p ?o }") is True  # the killed worker was replaced


# --- the engine's reading, and workers that cannot reach the network -----------------------------------

class _Remote:
    """A local HTTP server standing for any address the engine could be made to fetch; `hits` are its requests."""

    def __init__(self):
        self.hits: list[str] = []
        hits = self.hits

        class Handler(http.server.BaseHTTPRequestHandler):
            def do_GET(self):
                hits.append(self.path)
                self.send_response(500)
                self.end_headers()
                self.wfile.write(b"internal secret")

            do_POST = do_GET

            def log_message(self, *args):
                pass

        self.server = http.server.HTTPServer(("127.0.0.1", 0), Handler)
        self.url = f"http://127.0.0.1:{self.server.server_port}/"
        threading.Thread(target=self.server.serve_forever, daemon=True).start()

    def close(self):
        self.server.shutdown()
        self.server.server_close()


@pytest.fixture
def remote():
    r = _Remote()
    yield r
    r.close()


def _fetching_queries(url: str) -> list[str]:
    """SERVICE written every way Oxigraph's parser reads it: after a comment ended by CR (the grammar's other
    line end), lower case, glued to SILENT or to its IRI, as the prefix of a prefixed name (`SERVICE:x` is
    SERVICE :x), after a triple with no dot."""
    p = f"PREFIX : <{url}> PREFIX X: <{url}> "
    return [f"SELECT * WHERE {{ #x\rSERVICE <{url}a> {{ ?s ?p ?o }} }}",
            f"SELECT * WHERE {{ #x\r\tservice <{url}b> {{ ?s ?p ?o }} }}",
            f"SELECT * WHERE {{ SERVICESILENT<{url}c> {{ ?s ?p ?o }} }}",
            f"SELECT * WHERE {{ SERVICE<{url}d>{{ ?s ?p ?o }} }}",
            p + "SELECT * WHERE { SERVICE:e { ?s ?p ?o } }",
            p + "SELECT * WHERE { SERVICEX:f { ?s ?p ?o } }",
            p + "SELECT * WHERE { BIND(1 AS ?x) SERVICE :g { ?s ?p ?o } }"]


def test_every_way_the_engine_reads_service_is_refused(kb, remote):
    """Each query makes a bare Oxigraph store fetch (so the engine really reads SERVICE there); the server
    refuses each with 400 and fetches nothing, as a plain cross-site GET could send them."""
    api, _ = kb
    for q in _fetching_queries(remote.url):
        before = len(remote.hits)
        try:
            for _ in ox.Store().query(q):  # type: ignore[union-attr]  # a SELECT: solutions
                pass
        except OSError:  # the remote's 500 (SILENT ignores it)
            pass
        assert len(remote.hits) == before + 1, q  # the engine fetched
        status, ctype, body = api("GET", "/sparql?" + urllib.parse.urlencode({"query": q}))
        assert status == 400 and b"SERVICE" in body and b"secret" not in body, (q, body)
        assert len(remote.hits) == before + 1, q  # the server did not


def test_load_written_as_the_engine_reads_it_is_refused(kb, remote):
    api, _ = kb
    for text in (f"#x\rLOAD <{remote.url}a>", f"LOADSILENT<{remote.url}b>", f"PREFIX : <{remote.url}> LOAD:c",
                 f"PREFIX : <{remote.url}> INSERT {{ ?s ?p ?o }} WHERE {{ #\rSERVICE:d {{ ?s ?p ?o }} }}"):
        status, _, body = update(api, text)
        assert status == 400, (text, body)
    assert remote.hits == []


def test_a_refused_text_is_refused_every_time_it_is_sent(kb, remote):
    """The checks' result is kept per text: a refusal never is, nor does a text that passed let another through."""
    api, _ = kb
    fetching = f"SELECT * WHERE {{ SERVICE <{remote.url}> {{ ?s ?p ?o }} }}"
    for text in ("SELECT * WHERE { ?s ?p ?o } LIMIT 1", fetching, fetching, "SELECT * WHERE { ?s ?p ?o } LIMIT 1 ", fetching):
        status, _, body = api("GET", "/sparql?" + urllib.parse.urlencode({"query": text}))
        assert status == (400 if "SERVICE" in text else 200), (text, body)
    assert remote.hits == []


def test_nesting_hidden_behind_a_cr_comment_is_counted(kb_workers):
    api, _ = kb_workers
    q = "SELECT * WHERE { #x\r" + "{" * 60_000 + "}" * 60_000 + " }"
    status, _, body = api("POST", "/sparql", q.encode(), {"Content-Type": "application/sparql-query"})
    assert status == 400 and b"nests more than" in body


def _service_in_a_confined_worker(url: str, answer) -> None:
    from urdfkb.kb_server.index import _confine
    _confine(2**30)
    try:
        list(ox.Store().query(f"SELECT * WHERE {{ SERVICE <{url}z> {{ ?s ?p ?o }} }}"))  # type: ignore[arg-type]
        answer.send("fetched")
    except OSError as e:
        answer.send(str(e))


@pytest.mark.slow  # over a second of its own (make test-fast leaves it out)
def test_a_query_worker_can_open_no_connection_whatever_it_is_asked(remote):
    """The second line: were a SERVICE ever to pass the lexical checks, the worker has no socket to send it on."""
    ctx = multiprocessing.get_context("spawn")
    answer, child_end = ctx.Pipe(duplex=False)
    worker = ctx.Process(target=_service_in_a_confined_worker, args=(remote.url, child_end))
    worker.start()
    assert answer.poll(60)
    assert "Permission denied" in answer.recv()
    worker.join(10)
    assert remote.hits == []


@pytest.mark.slow
def test_a_query_past_its_memory_is_stopped_and_others_are_answered(pr2_kb, tmp_path):
    """Two cross-product ORDER BYs (gigabytes each, unbounded) end with 503 naming --query-memory, and another
    client's ASK is answered meanwhile by the third worker."""
    store = Store(copied(pr2_kb, tmp_path), workers=3, limits=ResultLimits(memory=512 * 2**20))
    app, jobs = make_app(store, token=TOKEN, query_timeout=10.0)
    api = client(app)
    heavy = "SELECT * WHERE { ?a ?b ?c . ?d ?e ?f } ORDER BY ?c ?f"
    statuses: list[tuple[int, bytes]] = []

    def run_heavy():
        status, _, body = api("POST", "/sparql", heavy.encode(), {"Content-Type": "application/sparql-query"})
        statuses.append((status, body))

    threads = [threading.Thread(target=run_heavy) for _ in range(2)]
    for t in threads:
        t.start()
    assert ask(api, "ASK {}") is True
    for t in threads:
        t.join(30)
    assert [s for s, _ in statuses] == [503, 503] and all(b"--query-memory" in b for _, b in statuses), statuses
    assert ask(api, f"ASK {{ GRAPH <{PR2_GRAPH}> {{ ?s ?p ?o }} }}") is True  # the workers were replaced
    jobs.shutdown()
    store.close()


@pytest.mark.slow  # over a second of its own (make test-fast leaves it out)
def test_an_update_that_breaks_the_shapes_is_refused_and_writes_nothing(kb):
    api, store = kb
    before = store.export("pr2", "nt")
    link = "<https://w3id.org/urdfkb/robot/pr2#stray>"
    status, _, body = update(api, f"INSERT DATA {{ GRAPH <{PR2_GRAPH}> {{ {link} a <{CORE}Link> }} }}")
    assert status == 400 and b"LinkShape" in body, body
    assert store.export("pr2", "nt") == before
    name = f'{link} <{CORE}urdfName> "stray"'
    assert update(api, f"INSERT DATA {{ GRAPH <{PR2_GRAPH}> {{ {link} a <{CORE}Link> . {name} }} }}")[0] == 204
