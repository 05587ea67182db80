"""Backends other than llama.cpp: the scripted test backend and the OpenAI-compatible HTTP client."""
import math

import pytest

from urdfkb.pipeline.llm.base import Question
from urdfkb.pipeline.llm.scripted import ScriptedBackend

OPTS = ("sensor", "gripper", "wheel")


def q(user="link: camera", options=OPTS):
    return Question(system="Classify the link.", user=user, options=options, key="kind:x")


def test_scripted_score_is_log_distribution():
    backend = ScriptedBackend(lambda _: {"sensor": 0.25, "wheel": 0.75})
    [row] = backend.score([q()])
    assert row[0] == pytest.approx(math.log(0.25))
    assert row[1] < -20
    assert row[2] == pytest.approx(math.log(0.75))
    assert ScriptedBackend(lambda _: "gripper").score([q()])[0][1] == 0.0
    assert backend.exposes_logits and backend.name == "scripted"


def test_scripted_sample_is_seeded_and_counts_calls():
    rule = lambda _: {"sensor": 0.5, "wheel": 0.5}  # noqa: E731
    a, b = ScriptedBackend(rule, seed=3), ScriptedBackend(rule, seed=3)
    assert a.sample(q(), 10, 0.7) == b.sample(q(), 10, 0.7)
    assert set(a.sample(q(), 50, 0.7)) == {"sensor", "wheel"}
    assert a.stats.calls == 60


# --- OpenAI-compatible HTTP backend against a real local server ----------------------------------

import json  # noqa: E402
import socket  # noqa: E402
import threading  # noqa: E402
import time  # noqa: E402
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer  # noqa: E402

from urdfkb.pipeline.errors import BackendError  # noqa: E402
from urdfkb.pipeline.llm.http import OpenAIBackend  # noqa: E402
from urdfkb.pipeline.abstraction.oracle import Oracle  # noqa: E402


def fake_server(behaviour):
    """Start an HTTP server on 127.0.0.1 whose POST handler is `behaviour(body) -> (status, bytes)`."""
    requests = []

    class Handler(BaseHTTPRequestHandler):
        def do_POST(self):
            body = json.loads(self.rfile.read(int(self.headers["Content-Length"])))
            requests.append((self.path, dict(self.headers), body))
            status, payload = behaviour(body)
            self.send_response(status)
            self.send_header("Content-Type", "application/json")
            self.send_header("Content-Length", str(len(payload)))
            self.end_headers()
            try:
                self.wfile.write(payload)
            except OSError:
                pass

        def log_message(self, *args):
            pass

    server = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
    server.daemon_threads = True
    threading.Thread(target=server.serve_forever, args=(0.05,), daemon=True).start()  # shutdown() waits one poll
    return server, f"http://127.0.0.1:{server.server_address[1]}", requests


def completion(texts):
    return 200, json.dumps({
        "choices": [{"index": i, "message": {"role": "assistant", "content": t}} for i, t in enumerate(texts)],
        "usage": {"prompt_tokens": 40, "completion_tokens": len(texts)},
    }).encode()


@pytest.fixture
def serve():
    servers = []

    def start(behaviour):
        server, url, requests = fake_server(behaviour)
        servers.append(server)
        return url, requests

    yield start
    for server in servers:
        server.shutdown()
        server.server_close()


def test_http_sample_with_n(serve):
    url, requests = serve(lambda body: completion(["sensor"] * body["n"]))
    backend = OpenAIBackend(url + "/v1", "qwen", api_key="k")
    assert backend.sample(q(), 3, 0.7) == ["sensor"] * 3
    path, headers, body = requests[0]
    assert path == "/v1/chat/completions" and headers["Authorization"] == "Bearer k"
    assert body["model"] == "qwen" and body["temperature"] == 0.7 and body["n"] == 3
    assert "- gripper" in body["messages"][1]["content"] and body["messages"][0]["content"] == "Classify the link."
    assert backend.stats.calls == 1 and backend.stats.prompt_tokens == 40
    assert not backend.exposes_logits and backend.name == f"openai:{url}/v1:qwen"


def test_http_server_ignoring_n_gets_separate_requests(serve):
    url, requests = serve(lambda body: completion([" Wheel\n"]))
    backend = OpenAIBackend(url, "m")
    assert backend.sample(q(), 4, 0.5) == [" Wheel\n"] * 4
    assert len(requests) == 4 and requests[0][0] == "/v1/chat/completions"
    [v] = Oracle(backend, votes=4).ask([q()])
    assert v.answer == "wheel" and v.confidence == 1.0


def test_http_out_of_set_answers_abstain(serve):
    url, _ = serve(lambda body: completion(["It is probably a sensor."] * body["n"]))
    [v] = Oracle(OpenAIBackend(url, "m"), votes=3, retries=1).ask([q()])
    assert v.answer is None and v.confidence == 0


def test_http_500_is_backend_error_that_never_quotes_the_body(serve):
    url, _ = serve(lambda body: (500, b'{"error": "secret internal detail"}'))
    with pytest.raises(BackendError, match=r"127\.0\.0\.1.*HTTP 500 Internal Server Error \(body of 35 bytes") as err:
        Oracle(OpenAIBackend(url, "m")).ask([q()])
    assert "secret" not in str(err.value)


@pytest.mark.parametrize("payload", [b"<html>secret", b'{"choices": [{"text": "secret"}]}', b'["secret"]', b'{"choices": []}'])
def test_http_garbage_is_backend_error_that_never_quotes_it(serve, payload):
    url, _ = serve(lambda body: (200, payload))
    with pytest.raises(BackendError, match="127.0.0.1") as err:
        OpenAIBackend(url, "m").sample(q(), 1, 0.7)
    assert "secret" not in str(err.value)


@pytest.mark.parametrize("url", ["file:///etc/passwd#", "ftp://127.0.0.1/x", "http:///v1", "127.0.0.1:8080"])
def test_http_backend_opens_only_http_urls(url):
    with pytest.raises(BackendError, match="must be http"):
        OpenAIBackend(url, "m")


def test_http_hang_times_out(serve):
    def hang(body):
        time.sleep(2)
        return completion(["sensor"])

    url, _ = serve(hang)  # without the timeout the reply would come, and no error would be raised
    with pytest.raises(BackendError, match="timed out after 0.5s"):
        OpenAIBackend(url, "m", timeout=0.5).sample(q(), 1, 0.7)


def test_http_connection_refused():
    with socket.socket() as sock:  # a port nobody listens on once closed
        sock.bind(("127.0.0.1", 0))
        url = f"http://127.0.0.1:{sock.getsockname()[1]}"
    with pytest.raises(BackendError, match="cannot reach"):
        OpenAIBackend(url, "m", timeout=2).sample(q(), 1, 0.7)


def test_http_has_no_logits():
    with pytest.raises(BackendError, match="vote='sample'"):
        OpenAIBackend("http://127.0.0.1:9", "m").score([q()])
    with pytest.raises(BackendError, match="log-probabilities"):
        Oracle(OpenAIBackend("http://127.0.0.1:9", "m"), vote="exact")


def test_openmp_threads_wait_passively_only_where_other_processes_keep_the_cores_busy(monkeypatch):
    """llama.cpp's threads spin at their barriers (libgomp's default) on idle cores, and sleep there when
    other processes keep at least half a core busy; a policy already set is left alone."""
    import os as _os

    from urdfkb.pipeline.llm import llama_process

    def choose(busy_elsewhere: float, own: float = 0.5, preset: dict | None = None) -> str | None:
        for name in ("OMP_WAIT_POLICY", "GOMP_SPINCOUNT"):
            monkeypatch.delenv(name, raising=False)
        for name, value in (preset or {}).items():
            monkeypatch.setenv(name, value)
        cores, ticks = _os.cpu_count() or 1, 100
        readings = iter([(0, 0), (cores * ticks, cores * ticks - int((busy_elsewhere + own) * ticks))])
        times = iter([_os.times_result((0, 0, 0, 0, 0)), _os.times_result((own * ticks / _os.sysconf("SC_CLK_TCK"), 0, 0, 0, 0))])
        monkeypatch.setattr(llama_process, "_cpu_ticks", lambda: next(readings))
        monkeypatch.setattr(llama_process.os, "times", lambda: next(times))
        monkeypatch.setattr(llama_process.time, "sleep", lambda seconds: None)
        llama_process.choose_openmp_waiting()
        return _os.environ.get("OMP_WAIT_POLICY")

    assert choose(busy_elsewhere=0.0) is None
    assert choose(busy_elsewhere=0.3) is None
    assert choose(busy_elsewhere=1.0) == "PASSIVE"
    assert choose(busy_elsewhere=1.0, preset={"OMP_WAIT_POLICY": "ACTIVE"}) == "ACTIVE"
    assert choose(busy_elsewhere=1.0, preset={"GOMP_SPINCOUNT": "10000"}) is None
