"""`urdfkb serve` start-up mistakes (a taken port, a file that is not a store, an unwritable store or folder,
a port out of range) end in one line naming the cause and the fix, exit status 2, no traceback; where no
sandbox can run, the server says in one line that xacro uploads need bubblewrap and how to install it."""
from __future__ import annotations

import os
import socket
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import pytest

from tests.kb_fixtures import free_port
from urdfkb.kb_server.serve import make_server
from urdfkb.kb_server.startup import check_port, check_store
from urdfkb.pipeline.errors import UrdfkbError

REPO = Path(__file__).resolve().parents[1]
ROOT = os.geteuid() == 0


@pytest.mark.parametrize("port", [-1, 65_536, 99_999])
def test_a_port_out_of_range_is_refused(port):
    with pytest.raises(UrdfkbError, match=f"--port {port} is not a TCP port: give one from 1 to 65,535"):
        check_port(port)


def test_a_file_that_is_not_a_store_is_refused_and_left_alone(tmp_path):
    notes = tmp_path / "notes.txt"
    notes.write_text("not a store\n")
    with pytest.raises(UrdfkbError, match=r"notes.txt is not a urdfkb store \(SQLite: file is not a database\): "
                                          "give --store a store file"):
        check_store(notes)
    assert notes.read_text() == "not a store\n"
    with pytest.raises(UrdfkbError, match="is a folder: give --store a file"):
        check_store(tmp_path)


def test_a_store_is_checked_without_being_changed(tmp_path):
    path = tmp_path / "kb.sqlite3"
    with sqlite3.connect(path) as db:
        db.execute("CREATE TABLE t (x)")
    before = path.read_bytes()
    assert check_store(path) == path and path.read_bytes() == before
    assert check_store(tmp_path / "new" / "kb.sqlite3").parent.is_dir()  # a new store's folder is made


@pytest.mark.skipif(not Path("/proc").is_dir(), reason="no /proc: a folder no user can write")
def test_a_folder_no_one_can_write_is_refused():
    with pytest.raises(UrdfkbError, match="cannot open or create the store /proc/kb.sqlite3: its folder /proc is "
                                          "not writable by this user"):
        check_store("/proc/kb.sqlite3")


@pytest.mark.skipif(ROOT, reason="root writes read-only files and folders")
def test_a_read_only_store_or_folder_is_refused(tmp_path):
    path = tmp_path / "kb.sqlite3"
    with sqlite3.connect(path) as db:
        db.execute("CREATE TABLE t (x)")
    path.chmod(0o444)
    with pytest.raises(UrdfkbError, match="is read-only for this user: make it writable"):
        check_store(path)
    path.chmod(0o644)
    tmp_path.chmod(0o555)  # the journal cannot be made beside the store
    try:
        with pytest.raises(UrdfkbError, match="not writable by this user"):
            check_store(path)
    finally:
        tmp_path.chmod(0o755)


def test_a_taken_port_is_refused_and_the_store_closed(tmp_path):
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        with pytest.raises(UrdfkbError, match=f"port {port} on 127.0.0.1 is in use .*: stop that server, or give "
                                              "another --port"):
            make_server(tmp_path / "kb.sqlite3", port=port)
    server, store, jobs = make_server(tmp_path / "kb.sqlite3", port=0)  # the store was closed: it opens again
    server.close()
    jobs.shutdown()
    store.close()


def serve(*args: str, env: dict | None = None, cwd: Path = REPO) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "urdfkb", "serve", *args], cwd=cwd, env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)


@pytest.mark.slow
def test_start_up_mistakes_end_in_one_line_without_a_traceback(tmp_path):
    notes = tmp_path / "notes.txt"
    notes.write_text("not a store\n")
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        cases = {f"port {port} on 127.0.0.1 is in use": ["--store", str(tmp_path / "kb.sqlite3"), "--port", str(port)],
                 "is not a urdfkb store": ["--store", str(notes)],
                 "--port 99999 is not a TCP port": ["--store", str(tmp_path / "kb.sqlite3"), "--port", "99999"]}
        for cause, args in cases.items():
            proc = serve(*args)
            _, err = proc.communicate(timeout=120)
            lines = err.splitlines()
            assert proc.returncode == 2 and len(lines) == 1 and lines[0].startswith("urdfkb: error: "), err
            assert cause in lines[0] and "Traceback" not in err


@pytest.mark.slow
def test_without_bubblewrap_serve_says_in_one_line_how_to_install_it(tmp_path):
    env = {**os.environ, "PATH": str(tmp_path / "no-bwrap-here")}  # shutil.which("bwrap") finds nothing
    proc = serve("--store", str(tmp_path / "kb.sqlite3"), "--port", str(free_port()), env=env)
    lines = []
    try:
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and (line := proc.stderr.readline()):  # type: ignore[union-attr]
            lines.append(line)
            if "serving" in line:
                break
    finally:
        proc.terminate()
        proc.wait(30)
    about = [line for line in lines if "xacro uploads" in line]
    assert len(about) == 1, lines
    assert "xacro uploads need the sandbox" in about[0] and "apt-get install bubblewrap" in about[0]
