"""xacro is code: uploads are expanded inside the operating system's boundary (pipeline.reading.sandbox),
in the job queue, with their output capped (issue 19). Each attack here worked on the code before."""
from __future__ import annotations

import contextlib
import json
import os
import re
import shutil
import socket
import subprocess
import sys
import sysconfig
import threading
import time
from pathlib import Path
from xml.sax.saxutils import quoteattr

import pytest

from tests.kb_fixtures import client, http, make_app, running
from urdfkb.kb_server.serve import make_server
from urdfkb.kb_server.store import Store
from urdfkb.pipeline.reading import sandbox
from urdfkb.pipeline.reading.xacro_input import XacroError, expand

XNS = 'xmlns:xacro="http://www.ros.org/wiki/xacro"'
ATTACKS = Path(__file__).parent / "data" / "sandbox" / "attacks.py"
EXPOSURE = Path(__file__).parent / "data" / "sandbox" / "exposure.py"
SPIN = Path(__file__).parent / "data" / "sandbox" / "spin.py"
EPERM = "refused: errno 1"
ENOENT = "refused: errno 2"
confined_only = pytest.mark.skipif(bool(sandbox.unavailable()), reason=f"no sandbox here: {sandbox.unavailable()}")

# A published escape from xacro's expression namespace: python.vars/python.type reach a function's
# __globals__ through string keys (the '__' check reads only names), then the real builtins' exec.
_GLOBALS_OF = "python.vars(python.type(xacro.load_yaml))['_'+'_globals_'+'_']"
_XACRO_GLOBALS = f"python.vars(python.type({_GLOBALS_OF}))['_'+'_get_'+'_']({_GLOBALS_OF}, xacro.load_yaml)"
_BUILTINS = f"{_XACRO_GLOBALS}['_'+'_builtins_'+'_']"


def escape(code: str) -> bytes:
    """A xacro document whose one expression runs `code` with the real builtins and the worker's
    module as `main`, its audit hook switched off first."""
    disarm = "main=G['sys'].modules['_'+'_main_'+'_']; main.audit.__code__=(lambda e, a: None).__code__\n"
    expr = (f"{_BUILTINS}['exec']({disarm + code!r}, "
            f"python.dict([('_'+'_builtins_'+'_', {_BUILTINS}), ('G', {_XACRO_GLOBALS})]))")
    return f'<robot name="r" {XNS}><link name={quoteattr("${" + expr + "}")}/></robot>'.encode()


def leak(code: str) -> bytes:
    """A xacro document whose one link is named by `code`'s value, evaluated with the real builtins as
    `B` once the audit hook is off (no double underscore in `code`: xacro refuses it)."""
    env = f"python.dict([('_'+'_builtins_'+'_', {_BUILTINS}), ('G', {_XACRO_GLOBALS}), ('B', {_BUILTINS})])"
    disarm = "G['sys'].modules['_'+'_main_'+'_'].audit.__code__=(lambda e, a: None).__code__"
    expr = f"[{_BUILTINS}['exec']({disarm!r}, {env}), {_BUILTINS}['eval']({code!r}, {env})][1]"
    return f'<robot name="leak" {XNS}><link name={quoteattr("${" + expr + "}")}/></robot>'.encode()


RUN_ID = "import subprocess; raise ValueError('uid_' + subprocess.run(['id', '-u'], capture_output=True, text=True).stdout.strip())"


def test_the_escape_runs_commands_without_the_sandbox():
    """Why the boundary exists: the interpreter's own guards are no boundary (the trusted path of the CLI)."""
    with pytest.raises(XacroError, match=r"uid_\d+"):
        expand(escape(RUN_ID), "escape.urdf.xacro")


@confined_only
def test_the_escape_runs_no_command_inside_the_sandbox():
    with pytest.raises(XacroError) as refused:
        expand(escape(RUN_ID), "escape.urdf.xacro", confined=True)
    assert not re.search(r"uid_\d", str(refused.value)) and "Operation not permitted" in str(refused.value)


@confined_only
def test_code_loose_in_the_sandbox_can_reach_nothing(tmp_path):
    """Whatever Python runs inside: no command, process, socket, signal or pidfd to the server,
    no host file, no /proc, no write to a package file or anywhere, no root."""
    package = tmp_path / "pkg"
    package.mkdir()
    (package / "part.xacro").write_text("<robot/>")
    package.chmod(0o755)
    (package / "part.xacro").chmod(0o644)
    secret = tmp_path / "secret.txt"
    secret.write_text("the server's")
    code, out, err = sandbox.run(ATTACKS, [str(os.getpid()), str(secret), "/packages/pkg/part.xacro"],
                                 {"/packages/pkg": package}, b"", 30, 65536)
    assert code == 0, err
    assert json.loads(out) == []
    assert (package / "part.xacro").read_text() == "<robot/>"


def test_a_flood_of_output_is_read_with_a_cap():
    """A child writing 100 MB to stderr (five times over HTTP grew the server by ~1 GB before)."""
    flood = "import sys\nfor _ in range(100): sys.stderr.write('x' * 1_000_000)\nprint('done')"
    code, out, err = sandbox.bounded_run([sys.executable, "-c", flood], b"", 60, 4096)
    assert code == 0 and out == b"done\n" and len(err) == 4096


@confined_only
def test_a_confined_expansion_that_floods_its_output_fails_cleanly():
    with pytest.raises(XacroError, match="expansion"):
        expand(escape("main.sys.stdout.write('x' * 50_000_000); main.sys.stdout.flush(); main.os._exit(0)"),
               "flood.urdf.xacro", confined=True, max_bytes=100_000)


def test_the_server_refuses_xacro_where_no_sandbox_can_run(tmp_path, monkeypatch):
    monkeypatch.setattr(sandbox, "unavailable", lambda: "bubblewrap (bwrap) is not installed")
    store = Store(tmp_path / "kb.sqlite3")
    doc = f'<robot name="plain" {XNS}><xacro:property name="b" value="b"/><link name="a"/><link name="${{b}}"/>' \
          '<joint name="j" type="fixed"><parent link="a"/><child link="b"/></joint></robot>'.encode()
    try:
        app, jobs = make_app(store)
        status, _, out = client(app)("POST", "/populate?structure_only=true", doc, {"Content-Type": "application/xml"})
        assert status == 403
        message = json.loads(out)["error"]
        assert "bubblewrap (bwrap) is not installed" in message and "--trust-xacro" in message
        jobs.shutdown()
        app, jobs = make_app(store, trust_xacro=True)  # the operator's explicit choice: expanded unconfined
        status, _, out = client(app)("POST", "/populate?structure_only=true", doc, {"Content-Type": "application/xml"})
        assert status == 202
        assert jobs.get(json.loads(out)["id"]).wait(30)
        assert [e.name for e in store.robots()] == ["plain"]
        jobs.shutdown()
    finally:
        store.close()


SLEEP = "__import__('time').sleep(60)"


def _populate(app, jobs, doc: bytes):
    """POST `doc` (a raw xacro body) and wait for its job: (job, seconds from the post to its end)."""
    started = time.monotonic()
    status, _, out = client(app)("POST", "/populate?structure_only=true", doc, {"Content-Type": "application/xml"})
    assert status == 202, out
    job = jobs.get(json.loads(out)["id"])
    assert job.wait(30)
    return job, time.monotonic() - started


@confined_only
def test_a_sleeping_xacro_job_ends_within_15_s(tmp_path):
    """Sleeping costs no CPU: before, only a 20 s wall clock ended it. Now the seccomp allow-list refuses
    the sleep (and the 10 s wall clock would end it otherwise)."""
    store = Store(tmp_path / "kb.sqlite3")
    try:
        app, jobs = make_app(store)
        job, seconds = _populate(app, jobs, escape(SLEEP))
        assert seconds < 15 and job.state == "failed", (seconds, job.errors)
        assert re.search(r"Operation not permitted|longer than 10 s, the xacro time limit", job.errors[0])
        jobs.shutdown()
    finally:
        store.close()


@confined_only
@pytest.mark.slow  # over a second of its own (make test-fast leaves it out)
def test_the_wall_clock_limit_ends_a_job_that_does_not_end(tmp_path):
    """A busy loop, with the server's --xacro-timeout 2: the job fails after 2 s, naming the limit."""
    store = Store(tmp_path / "kb.sqlite3")
    try:
        app, jobs = make_app(store, xacro_timeout=2)
        job, seconds = _populate(app, jobs, escape("while True: pass"))
        assert seconds < 5 and job.state == "failed", (seconds, job.errors)
        assert "longer than 2 s, the xacro time limit (wall time, --xacro-timeout)" in job.errors[0]
        jobs.shutdown()
    finally:
        store.close()


def _processes_running(marker: str, but: str | None = None) -> list[str]:
    """The pids of the processes with `marker` in their command line (but not those of program `but`)."""
    found = []
    for cmdline in Path("/proc").glob("[0-9]*/cmdline"):
        try:
            line = cmdline.read_bytes().decode("utf-8", "replace")
        except OSError:
            continue
        if marker in line and (but is None or not line.startswith(but + "\0")):
            found.append(cmdline.parent.name)
    return found


@pytest.mark.slow  # over a second of its own (make test-fast leaves it out)
def test_past_the_limit_the_whole_process_group_is_killed():
    """An (unconfined) expansion that starts a sleeper holding its output: the sleeper dies with it,
    and the limit is not stretched by waiting for the sleeper's pipe (before: 5 s more, sleeper alive)."""
    marker = "77.123"
    code = f"import subprocess; subprocess.Popen(['sleep', '{marker}']); {SLEEP}"
    started = time.monotonic()
    with pytest.raises(XacroError, match="longer than 2 s"):
        expand(escape(code), "sleeper.urdf.xacro", timeout=2)
    assert time.monotonic() - started < 4
    assert _processes_running(marker) == []


@pytest.mark.slow
@confined_only
def test_hostile_xacro_jobs_cost_no_other_route(tmp_path):
    """Twenty CPU-burning xacros: each is a job (a full queue answers 429 at once), expansion never
    runs on a request thread, and other routes answer within a second throughout."""
    burn = f'<robot name="burn" {XNS}><link name="${{9**9**9**9}}"/></robot>'.encode()
    server, store, jobs = make_server(tmp_path / "kb.sqlite3", port=0)
    with running(server):
        base = f"http://127.0.0.1:{server.effective_port}"
        started = time.monotonic()
        statuses = [http("POST", f"{base}/populate", burn, {"Content-Type": "application/xml"})[0] for _ in range(20)]
        posting = time.monotonic() - started
        assert set(statuses) == {202, 429} and statuses.count(202) >= 2
        assert posting < 10  # 20 posts answered without waiting for any expansion
        slowest = 0.0
        for _ in range(10):
            t = time.monotonic()
            status, _, _ = http("GET", f"{base}/robots")
            slowest = max(slowest, time.monotonic() - t)
            assert status == 200
            time.sleep(0.3)
        assert slowest < 1.0, slowest
    jobs.shutdown()
    store.close()


def _syscalls(*names: str) -> list[str]:
    """NAME=NUMBER of each system call on this machine, for exposure.py."""
    import pyseccomp
    return [f"{name}={pyseccomp.resolve_syscall(pyseccomp.system_arch(), name)}" for name in names]


def _exposure() -> dict:
    site = sysconfig.get_paths(vars={"base": sys.base_prefix, "platbase": sys.base_exec_prefix})["purelib"]
    calls = _syscalls("personality", "uname", "socket", "unshare", "sethostname")
    code, out, err = sandbox.run(EXPOSURE, [sys.prefix, site, *calls], {}, b"", 30, 65536)
    assert code == 0, err
    return json.loads(out)


def _assert_shows_only_what_expansion_needs(facts: dict) -> None:
    assert facts.pop("uid") == 65534  # nobody
    assert facts.pop("host name") == facts.pop("uname") == EPERM  # uname(2) is not on the allow-list
    assert facts.pop("/dev") == ["null", "urandom", "zero"]
    assert facts.pop("/dev/pts") == facts.pop("/dev/tty") == ENOENT
    assert not set(facts.pop("the root")) & {"bin", "sbin", "etc", "proc", "sys", "tmp", "home", "var", "run", "opt"}
    assert facts.pop("/usr/local") is facts.pop("/bin/sh") is False
    assert facts.pop("the venv") is (sys.prefix == sys.base_prefix)  # a venv is never mounted
    assert facts.pop("site-packages") in ([], ENOENT) and facts.pop("import pip") == "refused: ModuleNotFoundError"
    assert facts == {f"syscall {name}": EPERM for name in ("personality", "uname", "socket", "unshare", "sethostname")}


@confined_only
def test_the_sandbox_shows_only_what_expansion_needs():
    """Before: all of /usr (/usr/local too), the venv, the host's name, a full /dev where /dev/pts opened,
    and a deny-list letting ctypes make every other system call (personality, uname, sethostname...)."""
    _assert_shows_only_what_expansion_needs(_exposure())


@confined_only
def test_where_the_kernel_refuses_a_user_namespace_the_sandbox_runs_as_the_hosts_nobody(monkeypatch):
    if os.geteuid() != 0:
        pytest.skip("the fallback is for a server running as root")
    monkeypatch.setattr(sandbox, "_userns_refusal", lambda: "refused for the test")
    _assert_shows_only_what_expansion_needs(_exposure())


@confined_only
@pytest.mark.slow  # over a second of its own (make test-fast leaves it out)
def test_the_sandbox_has_its_own_user_namespace():
    """Before, a root server's sandbox shared the host's user namespace (setpriv only changed its uid)."""
    runner = threading.Thread(target=_run_briefly, args=(SPIN,))
    runner.start()
    try:
        namespaces: set[str] = set()
        deadline = time.monotonic() + 5
        while not namespaces and time.monotonic() < deadline:
            for pid in _processes_running(SPIN.name, but=shutil.which("bwrap")):  # python, not bwrap
                try:
                    namespaces.add(os.readlink(f"/proc/{pid}/ns/user"))
                except OSError:
                    pass
            time.sleep(0.05)
    finally:
        runner.join()
    assert namespaces and os.readlink("/proc/self/ns/user") not in namespaces


def _run_briefly(program: Path) -> None:
    """Run `program` confined for 2 s at most."""
    with contextlib.suppress(subprocess.TimeoutExpired):
        sandbox.run(program, [], {}, b"", 2, 4096)


HOST_FACTS = {
    "host name": "B['_'+'_import_'+'_']('socket').gethostname()",
    "uname": "'-'.join(B['_'+'_import_'+'_']('os').uname())",
    "/etc/hostname": "B['open']('/etc/hostname').read().strip()",
    "/proc": "B['open']('/proc/sys/kernel/hostname').read().strip()",
}


@confined_only
@pytest.mark.parametrize("fact", HOST_FACTS)
def test_host_facts_never_reach_the_store(tmp_path, fact):
    """Before, the host's name (through socket or uname) became a link's name in the store."""
    store = Store(tmp_path / "kb.sqlite3")
    host = {socket.gethostname(), "-".join(os.uname())}
    try:
        app, jobs = make_app(store)
        job, _ = _populate(app, jobs, leak(HOST_FACTS[fact]))
        graph = store.graph("leak")
        stored = {str(term) for triple in graph for term in triple} if graph is not None else set()
        assert not host & stored and not any(h in e for h in host for e in job.errors)
        assert job.state == "failed" and "Operation not permitted" in job.errors[0] or "No such file" in job.errors[0]
        jobs.shutdown()
    finally:
        store.close()


@confined_only
def test_at_most_one_sandbox_runs_per_core(monkeypatch):
    """Before, any number of sandboxes ran at once (the xacro loader let two through, whatever the cores)."""
    cores = len(os.sched_getaffinity(0))
    running_now, most, lock = [0], [0], threading.Lock()

    def fake_run(argv, stdin, timeout, max_output, **popen):
        with lock:
            running_now[0] += 1
            most[0] = max(most[0], running_now[0])
        time.sleep(0.2)
        with lock:
            running_now[0] -= 1
        return 0, b"", b""
    monkeypatch.setattr(sandbox, "bounded_run", fake_run)
    runs = [threading.Thread(target=sandbox.run, args=(SPIN, [], {}, b"", 5, 4096)) for _ in range(cores + 2)]
    for t in runs:
        t.start()
    for t in runs:
        t.join()
    assert most[0] == cores
