"""Nothing a stranger can make the server do (issue 8, item 5): each case was possible before.

Most cases use Flask's test client (Host `localhost`); a live waitress server where the socket
matters (header size, bound port, threads held by waiting clients)."""
import json
import logging
import re
import subprocess
import sys
import threading
import time
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from typing import Any

import pytest

from tests.kb_fixtures import PR2, fake_runner, http, live, multipart, running
from urdfkb.kb_server.app import create_app
from urdfkb.kb_server.jobs import JobManager, Runner, pipeline_runner
from urdfkb.kb_server.security import Policy, check_bind
from urdfkb.kb_server.serve import make_server
from urdfkb.pipeline.abstraction.components import Abstraction
from urdfkb.pipeline.errors import UrdfkbError
from urdfkb.pipeline.runner import Progress, Settings
from urdfkb.pipeline.reading.tree import KinematicTree

REPO = Path(__file__).resolve().parents[1]
TOY = Path(__file__).parent / "data" / "toy_robot.urdf"
XML = "application/xml"


@pytest.fixture
def kb(store):
    """make(runner=..., token=..., policy=..., jobs options...) -> (test client, jobs); all shut down after."""
    managers = []

    def make(runner=None, token=None, policy=None, max_links=5_000, max_waiters=4, **job_options):
        jobs = JobManager(store, runner or fake_runner({"pr2": PR2}), **job_options)
        managers.append(jobs)
        app = create_app(store, jobs, token=token, policy=policy, max_links=max_links, max_waiters=max_waiters)
        return app, jobs

    yield make
    for jobs in managers:
        jobs.shutdown()


def client(kb, **kw):
    return kb(**kw)[0].test_client()


def toy(name="toy") -> bytes:
    return TOY.read_bytes().replace(b'<robot name="toy_robot">', f'<robot name="{name}">'.encode())


class Recording:
    """`runner` that also lists the settings of every job it runs (`calls`)."""

    def __init__(self, runner: Runner = pipeline_runner):
        self.runner = runner
        self.calls: list[Settings] = []

    def __call__(self, tree: KinematicTree, settings: Settings, progress: Progress) -> Abstraction:
        self.calls.append(settings)
        return self.runner(tree, settings, progress)


def finished(app_jobs, job_id):
    job = app_jobs.get(job_id)
    assert job.wait(30)
    return job


# --- model and llm_url ------------------------------------------------------------------------


class RecordingServer(ThreadingHTTPServer):
    """An 'internal service': the paths it was asked for (`hits`), and the status it answers with."""

    def __init__(self, status: int):
        super().__init__(("127.0.0.1", 0), Recorder)
        self.hits: list[str] = []
        self.status = status


class Recorder(BaseHTTPRequestHandler):
    """Records every request and answers a secret with the server's `status`."""

    server: RecordingServer

    def do_POST(self):
        self.server.hits.append(self.path)
        body = b'{"secret": "SECRET-INTERNAL-42"}'
        self.send_response(self.server.status)
        self.send_header("Content-Length", str(len(body)))
        self.end_headers()
        self.wfile.write(body)

    def log_message(self, *args):
        pass


@pytest.fixture
def internal():
    """Start an internal HTTP service; yields start(status) -> (base URL, list of hits)."""
    servers = []

    def start(status=200):
        server = RecordingServer(status)
        threading.Thread(target=server.serve_forever, args=(0.05,), daemon=True).start()  # shutdown() waits one poll
        servers.append(server)
        return f"http://127.0.0.1:{server.server_address[1]}", server.hits

    yield start
    for server in servers:
        server.shutdown()
        server.server_close()


def test_llm_url_file_is_refused_and_nothing_is_read(kb):
    app, jobs = kb(runner=(runner := Recording()))
    r = app.test_client().post("/populate?llm_url=file%3A%2F%2F%2Fetc%2Fpasswd%23&use_cache=false", data=toy(),
                               content_type=XML)
    assert r.status_code == 403 and "--allow-llm-url" in r.json["error"] and "root:" not in r.get_data(as_text=True)
    jobs.shutdown()
    assert runner.calls == []  # nothing was queued
    with pytest.raises(UrdfkbError, match="http:// or https://"):
        Policy(llm_urls=["file:///etc/passwd"])


def test_llm_url_to_an_internal_service_is_refused_unless_allowed(kb, internal):
    url, hits = internal()
    app, jobs = kb(runner=(runner := Recording()))
    r = app.test_client().post(f"/populate?llm_url={url}/private%23&use_cache=false", data=toy(), content_type=XML)
    assert r.status_code == 403 and "--allow-llm-url" in r.json["error"]
    jobs.shutdown()
    assert hits == [] and runner.calls == []
    # Allowed: exactly the operator's base URL, never a path, query or fragment beneath it.
    app, jobs = kb(runner=pipeline_runner, policy=Policy(llm_urls=[url + "/v1/"]))
    c = app.test_client()
    for other in (f"{url}/private%23", f"{url}/v1/x%23", url):
        r = c.post(f"/populate?llm_url={other}", data=toy(), content_type=XML)
        assert r.status_code == 403 and f"{url}/v1" in r.json["error"], other
    assert hits == []
    r = c.post(f"/populate?llm_url={url}/v1&vote=sample&use_cache=false", data=toy(), content_type=XML)
    assert r.status_code == 202
    job = finished(jobs, r.json["id"])
    assert hits and job.state == "failed"  # the 'LLM' answered JSON that is no completion...
    assert "SECRET" not in " ".join(job.errors)  # ...and what it said is not repeated


def test_llm_server_error_body_is_never_echoed_in_the_job(kb, internal):
    url, hits = internal(status=500)
    app, jobs = kb(runner=pipeline_runner, policy=Policy(llm_urls=[url]))
    r = app.test_client().post(f"/populate?llm_url={url}&vote=sample&use_cache=false", data=toy(), content_type=XML)
    job = finished(jobs, r.json["id"])
    assert job.state == "failed" and "HTTP 500" in job.errors[0] and "SECRET" not in job.errors[0]


def test_model_paths_are_refused_alike_without_a_model_directory(kb):
    c = client(kb)
    answers = [c.post(f"/populate?model={path}", data=toy(), content_type=XML) for path in
               ("/etc/passwd", "/no/such/file.gguf", "../../etc/passwd")]
    assert {(r.status_code, r.get_data()) for r in answers} == {(answers[0].status_code, answers[0].get_data())}
    assert answers[0].status_code == 403 and "--model-dir" in answers[0].json["error"]


def test_model_dir_offers_its_gguf_files_by_name_only(kb, tmp_path):
    models = tmp_path / "models"
    models.mkdir()
    (models / "tiny.gguf").write_bytes(b"GGUF")
    (models / "notes.txt").write_text("not a model")
    (tmp_path / "outside.gguf").write_bytes(b"GGUF")
    seen = []

    def runner(tree, settings, progress):
        seen.append(settings.model)
        return fake_runner()(tree, settings, progress)

    app, jobs = kb(runner=runner, policy=Policy(model_dir=models))
    c = app.test_client()
    refusals = [c.post(f"/populate?model={m}", data=toy(), content_type=XML)
                for m in ("notes.txt", "../outside.gguf", str(tmp_path / "outside.gguf"), "missing.gguf", "/etc/passwd")]
    assert {r.status_code for r in refusals} == {400}
    assert {r.json["error"] for r in refusals} == {refusals[0].json["error"]}  # no clue whether a file exists
    assert "available: tiny.gguf" in refusals[0].json["error"]
    r = c.post("/populate?model=tiny.gguf", data=toy(), content_type=XML)
    assert r.status_code == 202 and finished(jobs, r.json["id"]).state == "succeeded"
    assert seen == [str(models.resolve() / "tiny.gguf")]


# --- link and joint counts ---------------------------------------------------------------------


def star(links: int) -> bytes:
    body = ['<link name="base"/>'] + [f'<link name="l{i}"/>' for i in range(1, links)]
    body += [f'<joint name="j{i}" type="fixed"><parent link="base"/><child link="l{i}"/></joint>' for i in range(1, links)]
    return f'<robot name="huge">{"".join(body)}</robot>'.encode()


def test_too_many_links_are_refused_before_the_pipeline(kb):
    """Counted as the upload is parsed in its job (never on the request thread): the pipeline never sees it."""
    app, jobs = kb(runner=(runner := Recording(fake_runner())), max_links=100)
    c = app.test_client()
    r = c.post("/populate", data=star(101), content_type=XML)
    assert r.status_code == 202
    done = c.get(f"/jobs/{r.json['id']}?wait=1").json
    assert done["state"] == "failed" and "too many links: 101, over the limit of 100" in done["errors"][0]
    r = c.post("/populate", data=star(100), content_type=XML)
    assert r.status_code == 202 and c.get(f"/jobs/{r.json['id']}?wait=1").json["state"] == "succeeded"
    jobs.shutdown()
    assert len(runner.calls) == 1


def test_a_huge_upload_is_parsed_in_its_job_and_refused_by_its_attribute_count(kb):
    """A 5.6 MB URDF of 700,000 attributes: the POST answers at once (the request thread parses nothing), the job
    fails naming the cap, and /robots answers meanwhile."""
    app, jobs = kb(runner=(runner := Recording(fake_runner())))
    c = app.test_client()
    attrs = " ".join(f'a{i}="1"' for i in range(100))
    doc = ('<robot name="big"><link name="l"/>' + f"<g {attrs}/>" * 7_000 + "</robot>").encode()
    assert len(doc) > 5_000_000
    started = time.monotonic()
    r = c.post("/populate", data=doc, content_type=XML)
    assert r.status_code == 202 and time.monotonic() - started < 2.0
    assert c.get("/robots").status_code == 200
    done = c.get(f"/jobs/{r.json['id']}?wait=1").json
    assert done["state"] == "failed" and "more than 250,000 XML attributes" in done["errors"][0], done
    jobs.shutdown()
    assert runner.calls == []


# --- bounded waits, queue, expiry --------------------------------------------------------------


def blocking_runner():
    release = threading.Event()

    def run(tree, settings, progress):
        assert release.wait(30)
        return fake_runner()(tree, settings, progress)

    return run, release


@pytest.mark.slow  # over a second of its own (make test-fast leaves it out)
def test_waiting_clients_are_capped_and_never_hold_every_thread(kb):
    run, release = blocking_runner()
    app, jobs = kb(runner=run, max_waiters=2)
    with live(app) as base:  # 6 server threads
        job_id = json.loads(http("POST", f"{base}/populate", toy(), {"Content-Type": XML})[2])["id"]
        results = []

        def wait_long():  # a probe below may hold a slot for a moment: retry on 429
            end = time.monotonic() + 60
            while (answer := http("GET", f"{base}/jobs/{job_id}?wait=1&timeout=30"))[0] == 429 and time.monotonic() < end:
                time.sleep(0.01)
            results.append(answer)

        waiters = [threading.Thread(target=wait_long) for _ in range(2)]
        for t in waiters:
            t.start()
        for _ in range(500):  # short waits fill a free slot and return; once both long waits hold theirs: 429
            status, _, out = http("GET", f"{base}/jobs/{job_id}?wait=1&timeout=0.01")
            if status == 429:
                break
        else:
            pytest.fail("a third waiter was never refused")
        assert "poll without wait" in json.loads(out)["error"]
        assert http("GET", f"{base}/robots")[0] == 200  # other clients are still answered
        assert http("GET", f"{base}/jobs/{job_id}?wait=1&timeout=nan")[0] == 400
        release.set()
        for t in waiters:
            t.join(30)
        assert [json.loads(out)["state"] for _, _, out in results] == ["succeeded", "succeeded"]


def test_populate_queue_is_bounded(kb):
    run, release = blocking_runner()
    app, jobs = kb(runner=run, workers=2, max_queued=3)
    c = app.test_client()
    try:
        accepted = [c.post(f"/populate?name=r{i}", data=toy(), content_type=XML) for i in range(5)]
        assert [r.status_code for r in accepted] == [202] * 5  # 2 running (or starting), 3 queued
        for _ in range(500):  # until both workers have taken their job
            if [c.get(f"/jobs/{r.json['id']}").json["state"] for r in accepted].count("queued") == 3:
                break
            time.sleep(0.01)
        r = c.post("/populate?name=r5", data=toy(), content_type=XML)
        assert r.status_code == 429 and r.headers["Retry-After"].isdigit() and "3 populate jobs" in r.json["error"]
    finally:
        release.set()


def test_finished_jobs_expire_with_a_clear_404(kb):
    app, jobs = kb(keep=2)
    c = app.test_client()
    ids = []
    for i in range(3):
        ids.append(c.post(f"/populate?name=r{i}", data=toy(), content_type=XML).json["id"])
        finished(jobs, ids[-1])
    assert [c.get(f"/jobs/{i}").status_code for i in ids] == [404, 200, 200]
    r = c.get(f"/jobs/{ids[0]}")
    assert "finished jobs are kept for 60 minutes, and only the last 2" in r.json["error"]
    app, jobs = kb(keep_seconds=0)
    c = app.test_client()
    job_id = c.post("/populate", data=toy(), content_type=XML).json["id"]
    finished(jobs, job_id)
    assert c.get(f"/jobs/{job_id}").status_code == 404


# --- cross-site writes -------------------------------------------------------------------------


def test_simple_cross_site_populate_is_refused(kb, store):
    c = client(kb)
    assert c.post("/populate", data=toy("pr2"), content_type=XML).status_code == 202  # curl-style: fine
    attacks: list[dict[str, Any]] = [
        dict(content_type="text/plain", headers={"Origin": "http://evil.example"}),
        dict(content_type="text/plain"),  # a browser that sends no Origin
        dict(content_type="application/x-www-form-urlencoded"),
        dict(content_type=XML, headers={"Origin": "null"}),
        dict(content_type=XML, headers={"Origin": "http://localhost:8001"}),
        dict(content_type=XML, headers={"Sec-Fetch-Site": "cross-site"}),
        dict(content_type="text/plain", headers={"Sec-Fetch-Site": "same-site"}),
    ]
    for attack in attacks:
        r = c.post("/populate?name=pr2&structure_only=true", data=toy("evil"), **attack)
        assert r.status_code == 403, attack
        assert "cross-" in r.json["error"] or "any web page" in r.json["error"]
    body, ctype = multipart({"name": "pr2"}, {"urdf": ("evil.urdf", toy("evil"))})
    assert c.post("/populate", data=body, content_type=ctype).status_code == 403
    assert c.post("/populate", data=body, content_type=ctype, headers={"Origin": "http://evil.example"}).status_code == 403


def test_our_own_pages_and_tools_can_still_write(kb):
    c = client(kb)
    body, ctype = multipart({"name": "a"}, {"urdf": ("a.urdf", toy())})
    same_origin = [
        dict(data=body, content_type=ctype, headers={"Origin": "http://localhost"}),  # a form on our own page
        dict(data=body, content_type=ctype, headers={"Sec-Fetch-Site": "same-origin"}),
        dict(data=body, content_type=ctype, headers={"X-Requested-With": "curl"}),
        dict(data=toy(), content_type="text/plain", headers={"Origin": "http://localhost", "Sec-Fetch-Site": "same-origin"}),
        dict(data=toy(), content_type=XML, headers={"Sec-Fetch-Site": "none"}),
    ]
    for request in same_origin:
        assert c.post("/populate", **request).status_code == 202, request


def test_token_writes_from_another_origin_are_refused(kb, store):
    c = client(kb, token="t")
    auth = {"Authorization": "Bearer t"}
    assert c.post("/populate", data=toy("pr2"), content_type="text/plain", headers=auth).status_code == 202
    evil = {**auth, "Origin": "http://evil.example"}
    assert c.delete("/robots/pr2", headers=evil).status_code == 403
    r = c.post("/sparql", data={"update": "CLEAR ALL"}, headers=evil)
    assert r.status_code == 403 and r.mimetype == "text/plain"
    r = c.post("/sparql", data={"query": "ASK {}"}, headers={"Origin": "http://evil.example"})
    assert r.status_code == 403
    assert c.post("/sparql", data={"query": "ASK {}"}).status_code == 200  # SPARQL clients POST forms


def test_the_allowed_host_is_an_allowed_origin(kb):
    c = client(kb, policy=Policy(allowed_hosts=["kb.example.org"]))
    r = c.post("/populate", data=toy(), content_type=XML,
               headers={"Host": "127.0.0.1:8000", "Origin": "https://kb.example.org"})  # behind a proxy
    assert r.status_code == 202


# --- Host (DNS rebinding) ----------------------------------------------------------------------


def test_unknown_host_is_refused_and_never_reflected(kb):
    c = client(kb)
    r = c.get("/sparql", headers={"Host": "rebind.evil.example"})
    assert r.status_code == 400 and b"evil" not in r.data and b"--allowed-host" in r.data
    assert c.get("/robots", headers={"Host": "rebind.evil.example:8000"}).status_code == 400
    r = c.get("/sparql", headers={"Host": "127.0.0.1:8000", "Accept": "text/turtle"})
    assert r.status_code == 200 and b"<http://127.0.0.1:8000/sparql>" in r.data


@pytest.mark.parametrize("bind, port, allowed, host, ok", [
    ("127.0.0.1", 8000, (), "127.0.0.1:8000", True),
    ("127.0.0.1", 8000, (), "localhost:8000", True),
    ("127.0.0.1", 8000, (), "[::1]:8000", True),
    ("127.0.0.1", 8000, (), "LOCALHOST:8000", True),
    ("127.0.0.1", 8000, (), "localhost:8001", False),
    ("127.0.0.1", 8000, (), "localhost", False),
    ("127.0.0.1", 80, (), "localhost", True),
    ("127.0.0.1", 8000, (), "127.0.0.1.nip.io:8000", False),
    ("127.0.0.1", 8000, (), "attacker.example:8000", False),
    ("127.0.0.1", 8000, (), "", False),
    ("127.0.0.1", 8000, (), "user@localhost:8000", False),
    ("127.0.0.1", 8000, (), "localhost:80000", False),
    ("127.0.0.1", None, (), "localhost:43210", True),
    ("192.168.1.5", 8000, (), "192.168.1.5:8000", True),
    ("192.168.1.5", 8000, (), "localhost:8000", False),
    ("kb.lan", 8000, (), "KB.lan:8000", True),
    ("0.0.0.0", 8000, (), "10.1.2.3:8000", True),
    ("0.0.0.0", 8000, (), "robot.lan:8000", False),
    ("0.0.0.0", 8000, ("robot.lan",), "robot.lan:8000", True),
    ("127.0.0.1", 8000, ("kb.example.org",), "kb.example.org", True),
    ("127.0.0.1", 8000, ("kb.example.org:443",), "kb.example.org:444", False),
    ("::", 8000, (), "[fe80::1]:8000", True),
])
def test_host_check(bind, port, allowed, host, ok):
    assert Policy(bind, port, allowed).host_allowed(host) is ok


def test_live_server_checks_host_against_its_bound_port(tmp_path):
    server, store, jobs = make_server(tmp_path / "kb.sqlite3", port=0, runner=fake_runner())
    try:
        with running(server):
            port = server.effective_port
            base = f"http://127.0.0.1:{port}"
            assert http("GET", f"{base}/robots")[0] == 200
            for host in (f"rebind.example:{port}", "localhost:1"):
                assert http("GET", f"{base}/robots", headers={"Host": host})[0] == 400, host
            status, _, out = http("GET", f"{base}/sparql?query=ASK%7B%7D", headers={"Accept": "x/" + "a" * 70_000})
            assert status == 431 and b"aaaa" not in out  # header over the size limit, never echoed
    finally:
        jobs.shutdown()
        store.close()


# --- non-loopback binds need a token -----------------------------------------------------------


@pytest.mark.slow
def test_non_loopback_bind_needs_a_token(tmp_path, caplog):
    for host in ("127.0.0.1", "::1", "localhost", "127.0.0.2"):
        check_bind(host, None)
    check_bind("0.0.0.0", "secret")
    for host in ("0.0.0.0", "::", "192.168.1.5", "robot.lan"):
        with pytest.raises(UrdfkbError, match="without a token.*--token.*--insecure-no-token"):
            check_bind(host, None)
    check_bind("0.0.0.0", None, insecure_no_token=True)
    assert "WITH NO TOKEN" in caplog.text
    proc = subprocess.run([sys.executable, "-m", "urdfkb", "serve", "--host", "0.0.0.0", "--port", "0",
                           "--store", str(tmp_path / "kb.sqlite3")], cwd=REPO, capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2 and "refusing to serve on 0.0.0.0 without a token" in proc.stderr


# --- never echo request headers; never 500 on a lone surrogate ---------------------------------


def test_accept_header_is_never_echoed(kb):
    r = client(kb).get("/sparql?query=ASK%7B%7D", headers={"Accept": "x/secret-" + "a" * 70_000})
    assert r.status_code == 406 and b"secret" not in r.data and len(r.data) < 1000


def test_lone_surrogate_in_an_error_message_is_escaped_not_a_500(kb):
    c = client(kb, token="t")
    r = c.post("/sparql", data={"update": 'INSERT { <x:a> <x:b> 1 } USING <\\uD800> WHERE {}'},
               headers={"Authorization": "Bearer t"})
    assert 400 <= r.status_code < 500
    r.get_data().decode("utf-8")  # well-formed


def test_bad_security_options_stop_the_server_with_a_clear_error(tmp_path):
    for options, message in ((dict(model_dir=tmp_path / "nope"), "--model-dir .*not a directory"),
                             (dict(llm_urls=["ftp://llm.lan"]), "--allow-llm-url .*http:// or https://"),
                             (dict(llm_urls=["http://llm.lan/v1#x"]), "no credentials, query or fragment"),
                             (dict(allowed_hosts=["a:b:c"]), "--allowed-host 'a:b:c'")):
        with pytest.raises(UrdfkbError, match=message):
            make_server(tmp_path / "kb.sqlite3", port=0, **options)


# --- errors kept with a job are cut ---------------------------------------------------------------


@pytest.mark.parametrize("fail", [UrdfkbError("\U0001F600" * 5_000_000), RuntimeError("x" * 5_000_000)])
def test_a_huge_job_error_is_cut_where_it_is_kept_and_logged(kb, caplog, fail):
    """A 614-byte xacro made a 19 MB job error, kept with the job and logged in full (security test, item 2)."""
    app, jobs = kb(runner=fake_runner(fail=fail))
    c = app.test_client()
    with caplog.at_level(logging.INFO, logger="urdfkb.kb_server.jobs"):
        job = finished(jobs, c.post("/populate", data=toy(), content_type=XML).json["id"])
    r = c.get(f"/jobs/{job.id}")
    assert job.state == "failed" and len(r.data) < 64 * 1024  # JSON escapes each emoji as 12 bytes
    assert re.search(r"\.\.\. \[cut: 5,000,0\d\d characters in all\]$", r.json["errors"][0])
    assert caplog.records and all(len(record.getMessage()) < 64 * 1024 for record in caplog.records)
