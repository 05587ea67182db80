"""`urdfkb serve` answers SPARQL queries where waitress finishes reading them (kb_server.sparql_front): the same
answers as the app's route, the same headers as the app's answers, keep-alive and pipelining as waitress
does them; refusals of the request itself and everything else still reach the app."""
import socket
import threading
import urllib.parse

import pytest

from tests.kb_fixtures import copied, fake_runner, http, running
from urdfkb.kb_server.serve import make_server

QUERY = "SELECT ?c ?m WHERE { ?c <https://w3id.org/urdfkb/core#isMountedOn> ?m } ORDER BY ?c ?m"
FORM = {"Content-Type": "application/x-www-form-urlencoded"}


@pytest.fixture(scope="module")
def served(pr2_kb, tmp_path_factory):
    """(base URL, server, store) of a live server over PR2, its workers ready."""
    srv, store, jobs = make_server(copied(pr2_kb, tmp_path_factory.mktemp("kb")), port=0, runner=fake_runner(),
                                   token="t")
    try:
        with running(srv):
            store.query("ASK {}", 60)  # the workers have loaded their replicas
            yield f"http://127.0.0.1:{srv.effective_port}", srv, store
    finally:
        jobs.shutdown()
        store.close()


@pytest.fixture
def app_requests(served, monkeypatch):
    """The requests handed to waitress's task threads (the app) from now on."""
    _, srv, _ = served
    handed = []
    real = srv.task_dispatcher.add_task

    def add_task(channel):
        handed.append(channel.requests[0].path)
        real(channel)
    monkeypatch.setattr(srv.task_dispatcher, "add_task", add_task)
    return handed


def test_queries_every_way_are_answered_without_the_app_as_the_app_answers(served, app_requests):
    base, _, store = served
    expected = store.query(QUERY).body
    q = urllib.parse.urlencode({"query": QUERY})
    answers = [http("GET", f"{base}/sparql?{q}"), http("POST", f"{base}/sparql", q.encode(), FORM),
               http("POST", f"{base}/sparql", QUERY.encode(), {"Content-Type": "application/sparql-query"})]
    assert app_requests == []
    assert [(status, ctype, body) for status, ctype, body in answers] == \
        [(200, "application/sparql-results+json; charset=utf-8", expected)] * 3
    refused = http("POST", f"{base}/sparql", b"SELEC", {"Content-Type": "application/sparql-query"})
    assert refused[:2] == (400, "text/plain; charset=utf-8") and refused[2].startswith(b"SPARQL syntax error")
    assert app_requests == []


def _raw(base: str, data: bytes) -> bytes:
    """What the server sends back to `data` (HOST standing for the server's host:port) on one connection, until
    it closes it or is quiet for 2 s."""
    netloc = urllib.parse.urlsplit(base).netloc
    host, port = netloc.split(":")
    with socket.create_connection((host, int(port)), timeout=2) as s:
        s.sendall(data.replace(b"HOST", netloc.encode()))
        out = b""
        try:
            while chunk := s.recv(65536):
                out += chunk
        except TimeoutError:
            pass
    return out


def _request(version: str, connection: str = "", query: str = QUERY) -> bytes:
    extra = f"Connection: {connection}\r\n" if connection else ""
    return (f"GET /sparql?{urllib.parse.urlencode({'query': query})} HTTP/{version}\r\nHost: HOST\r\n"
            f"{extra}\r\n").encode()


def test_the_answer_has_the_headers_of_the_apps_answers_and_keeps_the_connection_as_waitress_does(served):
    base, _, _ = served
    one = _raw(base, _request("1.1", "close"))
    head = one.split(b"\r\n\r\n")[0].decode().split("\r\n")
    assert head[0] == "HTTP/1.1 200 OK"
    page = _raw(base, b"GET /sparql HTTP/1.1\r\nHost: HOST\r\nAccept: text/turtle\r\nConnection: close\r\n\r\n")
    names = sorted(line.split(":")[0] for line in head[1:])
    assert names == sorted(line.split(":")[0] for line in page.split(b"\r\n\r\n")[0].decode().split("\r\n")[1:]) \
        == ["Connection", "Content-Length", "Content-Type", "Date", "Server", "Urdfkb-Max-Body"]
    assert _raw(base, _request("1.0")).startswith(b"HTTP/1.0 200 OK")  # and closed: no timeout needed
    kept = _raw(base, _request("1.0", "keep-alive") + _request("1.0"))
    assert kept.count(b"HTTP/1.0 200 OK") == 2 and b"Connection: Keep-Alive" in kept


def test_pipelined_requests_are_answered_in_order_whoever_answers_them(served, app_requests):
    base, _, _ = served
    ask = "ASK { ?s ?p ?o }"
    out = _raw(base, _request("1.1", query=QUERY) + b"GET /robots HTTP/1.1\r\nHost: HOST\r\n\r\n"
               + _request("1.1", query=ask) + _request("1.1", "close", query="SELEC"))
    answers = out.split(b"HTTP/1.1 ")[1:]
    assert [a[:3] for a in answers] == [b"200", b"200", b"200", b"400"]
    assert b'"m":' in answers[0] and b'"name":"pr2"' in answers[1] and b'"boolean":true' in answers[2]
    assert app_requests == ["/robots"]


@pytest.mark.parametrize("request_, status", [
    (("GET", "/sparql?query=ASK%7B%7D", None, {"Host": "evil.example"}), 400),
    (("POST", "/sparql", b"query=ASK%7B%7D", {**FORM, "Origin": "http://evil.example"}), 403),
    (("POST", "/sparql", b"query=ASK%7B%7D&update=CLEAR%20ALL", FORM), 400),
    (("POST", "/sparql", b"update=CLEAR%20DEFAULT", FORM), 403),
])
def test_refusals_of_the_request_itself_are_the_apps(served, app_requests, request_, status):
    base, _, _ = served
    method, path, body, headers = request_
    got, ctype, _ = http(method, base + path, body, headers)
    assert (got, ctype) == (status, "text/plain; charset=utf-8") and app_requests == ["/sparql"]


@pytest.fixture
def submitted(served, monkeypatch):
    """The queries handed to the query workers from now on."""
    _, _, store = served
    ops = []
    real = store.index.submit

    def submit(op, args, timeout, done):
        if op == "query":
            ops.append(args[0])
        real(op, args, timeout, done)
    monkeypatch.setattr(store.index, "submit", submit)
    return ops


FRONT_VALUE = "SELECT ?o WHERE { GRAPH <urn:x:front> { <urn:x:s> <urn:x:p> ?o } }"


def _set_front_value(base: str, value: int) -> None:
    update = ("DELETE WHERE { GRAPH <urn:x:front> { <urn:x:s> <urn:x:p> ?o } }; "
              f"INSERT DATA {{ GRAPH <urn:x:front> {{ <urn:x:s> <urn:x:p> {value} }} }}")
    status, _, body = http("POST", f"{base}/sparql", update.encode(),
                           {"Content-Type": "application/sparql-update", "Authorization": "Bearer t"})
    assert status == 204, body


def _front_value(base: str, headers: dict | None = None) -> bytes:
    status, _, body = http("GET", f"{base}/sparql?{urllib.parse.urlencode({'query': FRONT_VALUE})}", None, headers)
    assert status == 200, body
    return body


def test_a_query_asked_again_is_answered_from_the_cache_until_a_write(served, app_requests, submitted):
    base, _, _ = served
    _set_front_value(base, 1)
    first = _front_value(base)
    assert b'"value":"1"' in first and submitted == [FRONT_VALUE]
    assert _front_value(base) == first and submitted == [FRONT_VALUE]  # no worker asked
    assert _front_value(base, {"Cache-Control": "no-cache"}) == first and submitted == [FRONT_VALUE] * 2
    _set_front_value(base, 2)
    assert b'"value":"2"' in _front_value(base) and submitted == [FRONT_VALUE] * 3
    refused = "SELECT * WHERE { SERVICE <http://example.org/> { ?s ?p ?o } }"
    for _ in range(2):  # refused by its worker each time: never kept
        status, _, body = http("GET", f"{base}/sparql?{urllib.parse.urlencode({'query': refused})}")
        assert status == 400 and body.startswith(b"SERVICE")
    assert submitted == [FRONT_VALUE] * 3 + [refused] * 2
    assert app_requests == ["/sparql"] * 2  # the updates


def test_pipelined_answers_from_the_cache_keep_their_order_and_nothing_follows_a_close(served, app_requests,
                                                                                       submitted):
    base, _, _ = served
    ask = "ASK { ?s a ?c }"
    expected = [_raw(base, _request("1.1", "close", query=q)).split(b"\r\n\r\n", 1)[1] for q in (QUERY, ask)]
    out = _raw(base, _request("1.1", query=QUERY) + b"GET /robots HTTP/1.1\r\nHost: HOST\r\n\r\n"
               + _request("1.1", query=ask) + _request("1.1", "close", query=QUERY) + _request("1.1", query=ask))
    answers = out.split(b"HTTP/1.1 ")[1:]
    assert [a[:3] for a in answers] == [b"200"] * 4
    bodies = [a.split(b"\r\n\r\n", 1)[1] for a in answers]
    assert [bodies[0], bodies[2], bodies[3]] == [expected[0], expected[1], expected[0]] and b'"name":"pr2"' in bodies[1]
    assert app_requests == ["/robots"] and submitted == [QUERY, ask]  # the two asked first, before they were kept


@pytest.mark.slow  # over a second of its own (make test-fast leaves it out)
def test_a_query_sent_after_a_write_was_answered_sees_it_whatever_others_read_meanwhile(served):
    base, _, _ = served
    _set_front_value(base, 0)
    stop, seen = threading.Event(), []

    def read() -> None:
        while not stop.is_set():
            seen.append(_front_value(base))
    readers = [threading.Thread(target=read) for _ in range(2)]
    for r in readers:
        r.start()
    try:
        for i in range(1, 16):
            _set_front_value(base, i)
            assert f'"value":"{i}"'.encode() in _front_value(base)
    finally:
        stop.set()
        for r in readers:
            r.join(10)
    assert len(seen) > 15
