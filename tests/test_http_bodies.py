"""Bodies over the limit are answered with the app's 413, which ordinary clients read (urllib saw a reset
connection or a broken pipe, curl waitress's plain-text page), and `Expect: 100-continue` gets the refusal,
not "100 Continue". The client refuses such a document before sending it."""
from __future__ import annotations

import json
import socket
import time
import urllib.error
import urllib.request
from contextlib import contextmanager

import pytest

from tests.kb_fixtures import fake_runner, running
from urdfkb.client import KnowledgeBase, TooLarge
from urdfkb.kb_server import http_bodies
from urdfkb.kb_server.serve import make_server

LIMIT = 1_000_000


@contextmanager
def serving(folder, **options):
    """A live server (make_server) whose body limit is LIMIT bytes, with `options`; yields its port."""
    srv, store, jobs = make_server(folder / "kb.sqlite3", port=0, runner=fake_runner(), max_body=LIMIT, **options)
    try:
        with running(srv):
            yield srv.effective_port
    finally:
        jobs.shutdown()
        store.close()


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    with serving(tmp_path_factory.mktemp("kb")) as port:
        yield port


def head(port: int, length: int, extra: str = "", path: str = "/populate") -> bytes:
    return (f"POST {path} HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nContent-Type: application/xml\r\n"
            f"Content-Length: {length}\r\n{extra}\r\n").encode()


def answer(sock: socket.socket) -> bytes:
    """Everything the server sends until it closes the connection."""
    out = b""
    while chunk := sock.recv(65536):
        out += chunk
    return out


def test_urllib_reads_the_413_of_a_64_mib_body(server):
    request = urllib.request.Request(f"http://127.0.0.1:{server}/populate", data=bytes(64 * 2**20),
                                     headers={"Content-Type": "application/xml"})
    with pytest.raises(urllib.error.HTTPError) as refused:
        urllib.request.urlopen(request, timeout=30)
    assert refused.value.code == 413 and refused.value.headers["Content-Type"] == "application/json"
    assert json.loads(refused.value.read()) == {"error": f"request body larger than the {LIMIT} byte limit"}
    assert refused.value.headers[http_bodies.MAX_BODY_HEADER] == str(LIMIT)


def test_the_refusal_comes_before_the_body_and_the_connection_closes_once_the_body_is_in(server):
    with socket.create_connection(("127.0.0.1", server), timeout=10) as s:
        s.sendall(head(server, 8 * LIMIT))
        first = s.recv(65536)
        assert first.startswith(b"HTTP/1.1 413 ") and b"Connection: close" in first
        s.sendall(bytes(8 * LIMIT))  # read and dropped by the server: no reset, no broken pipe
        rest = first + answer(s)
    assert rest.endswith(f'{{"error":"request body larger than the {LIMIT} byte limit"}}\n'.encode())


def test_expect_100_continue_gets_the_refusal_instead_of_continue(server):
    with socket.create_connection(("127.0.0.1", server), timeout=10) as s:
        s.sendall(head(server, 64 * 2**20, "Expect: 100-continue\r\n"))
        reply = answer(s)  # closed after the answer: no body is awaited
    assert reply.startswith(b"HTTP/1.1 413 ") and b"100 Continue" not in reply
    assert reply.endswith(f"{LIMIT} byte limit\"}}\n".encode())


def test_on_sparql_the_refusal_is_plain_text(server):
    with socket.create_connection(("127.0.0.1", server), timeout=10) as s:
        s.sendall(head(server, 2 * LIMIT, "Expect: 100-continue\r\n", "/sparql"))
        reply = answer(s)
    assert reply.startswith(b"HTTP/1.1 413 ") and b"Content-Type: text/plain" in reply
    assert reply.endswith(f"request body larger than the {LIMIT} byte limit\n".encode())


def test_a_body_beyond_the_discard_bound_is_answered_and_cut_off(server, monkeypatch):
    monkeypatch.setattr(http_bodies, "MAX_DISCARD", 4 * LIMIT)
    with socket.create_connection(("127.0.0.1", server), timeout=10) as s:
        s.sendall(head(server, 5 * LIMIT))
        reply = answer(s)  # closed at once, without waiting for the body
    assert reply.startswith(b"HTTP/1.1 413 ")


@pytest.mark.slow
def test_a_refused_body_that_never_comes_is_cut_off_at_the_body_deadline(tmp_path):
    with serving(tmp_path, body_timeout=2) as port, socket.create_connection(("127.0.0.1", port), timeout=10) as s:
        s.sendall(head(port, 8 * LIMIT) + bytes(1000))
        started = time.monotonic()
        assert answer(s).startswith(b"HTTP/1.1 413 ")
        assert 1.5 < time.monotonic() - started < 10  # the 2 s body deadline, not the 30 s idle timeout


def test_the_client_refuses_a_document_over_the_servers_limit_unsent(server, tmp_path):
    kb = KnowledgeBase(f"http://127.0.0.1:{server}")
    assert kb.max_body() == LIMIT
    big = tmp_path / "big.urdf"
    big.write_bytes(bytes(LIMIT + 1))
    for document in (big, bytes(LIMIT + 1)):
        with pytest.raises(TooLarge, match="1,000,001 bytes, over the 1,000,000-byte limit of the urdfkb server") as e:
            kb.populate(document)
        assert (e.value.size, e.value.limit) == (LIMIT + 1, LIMIT)
    robot = b'<robot name="tiny"><link name="a"/></robot>'
    job = kb.job(kb.populate(robot, structure_only=True)["id"], wait=True)
    assert job["state"] == "succeeded" and job["robot"] == "tiny"
