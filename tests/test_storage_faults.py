"""A write the store's disk refuses is a named error, never a 500: a full disk answers 507, a read-only or failing
one 503, naming the disk (the store file's directory), for SPARQL Update, populate and corrections; it is logged
as the operator's fault, without a traceback, and nothing is half-written. Faults are injected at the save; a
real full disk is a small tmpfs, where this machine lets the tests mount one."""
from __future__ import annotations

import json
import logging
import os
import sqlite3
import subprocess

import pytest

from tests.kb_fixtures import PR2, client, make_app
from urdfkb.kb_server.errors import DiskFull
from urdfkb.kb_server.store import Store

TOKEN = "t0ken"
AUTH = {"Authorization": f"Bearer {TOKEN}"}
UPDATE = 'INSERT DATA { GRAPH <urn:x:g> { <urn:x:s> <urn:x:p> "o" } }'
COUNT = "SELECT (COUNT(*) AS ?n) WHERE { GRAPH ?g { ?s ?p ?o } }"
FAULTS = [(sqlite3.SQLITE_FULL, "database or disk is full", 507, "is full"),
          (sqlite3.SQLITE_READONLY, "attempt to write a readonly database", 503, "is read-only"),
          (sqlite3.SQLITE_IOERR_WRITE, "disk I/O error", 503, "failed a write")]


def fail_next_save(store: Store, code: int, message: str) -> None:
    """The store's next commit fails as SQLite fails it: the error with its code (the world it belongs to is
    reopened after the failure, so only that one commit fails)."""
    def save(*args, **kwargs):
        error = sqlite3.OperationalError(message)
        error.sqlite_errorcode = code
        raise error
    store.world.save = save


def stored(store: Store) -> tuple:
    """What the store holds: its robots, their corrections, the number of quads SPARQL sees."""
    return ([e.to_dict() for e in store.robots()], store.corrections("pr2"), store.query(COUNT).as_dicts()[0]["n"])


@pytest.fixture
def api(pr2_store):
    app, jobs = make_app(pr2_store, token=TOKEN)
    yield client(app), pr2_store
    jobs.shutdown()


@pytest.mark.parametrize("code, message, status, says", FAULTS)
@pytest.mark.slow  # over a second of its own (make test-fast leaves it out)
def test_a_refused_write_is_named_logged_and_leaves_the_store_as_it_was(api, shared, caplog, code, message, status, says):
    call, store = api
    disk = str(store.path.resolve().parent)
    before = stored(store)
    correction = json.dumps({"action": "confirm", "links": ["base_laser_link"], "reviewer": "Ann"}).encode()
    with caplog.at_level(logging.INFO):
        fail_next_save(store, code, message)
        got, ctype, out = call("POST", "/sparql", UPDATE.encode(), {"Content-Type": "application/sparql-update", **AUTH})
        assert (got, ctype.split(";")[0]) == (status, "text/plain") and disk in out.decode() and says in out.decode()

        fail_next_save(store, code, message)
        got, _, out = call("POST", "/robots/pr2/corrections", correction, {"Content-Type": "application/json", **AUTH})
        assert got == status and disk in json.loads(out)["error"]

        fail_next_save(store, code, message)
        got, _, out = call("POST", "/populate?name=pr2", (shared / "urdf" / "pr2.urdf").read_bytes(), AUTH)
        job = json.loads(call("GET", f"/jobs/{json.loads(out)['id']}?wait=1&timeout=60")[2])
        assert job["state"] == "failed" and disk in job["errors"][0] and says in job["errors"][0], job
    assert stored(store) == before
    refused = [r for r in caplog.records if r.name == "urdfkb.kb_server.store" and r.levelno == logging.ERROR]
    assert len(refused) == 3 and all(disk in r.getMessage() for r in refused)
    assert "Traceback" not in caplog.text and "internal error" not in caplog.text
    assert call("POST", "/robots/pr2/corrections", correction, {"Content-Type": "application/json", **AUTH})[0] == 201


@pytest.fixture
def small_disk(tmp_path):
    """A 24 MB tmpfs mounted at tmp_path/disk (skips where this machine does not let the tests mount one)."""
    disk = tmp_path / "disk"
    disk.mkdir()
    mounted = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=24m", "tmpfs", str(disk)], capture_output=True, text=True)
    if mounted.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here: {mounted.stderr.strip() or mounted.returncode}")
    yield disk
    subprocess.run(["umount", str(disk)], check=True)


@pytest.mark.slow
def test_a_full_disk_refuses_populate_and_update_by_name_and_the_store_survives(small_disk, shared):
    from urdfkb.pipeline.reading.ingest import load_urdf

    pr2, panda = (load_urdf(shared / "urdf" / f"{n}.urdf") for n in ("pr2", "panda"))
    store = Store(small_disk / "kb.sqlite3", workers=0)
    try:
        store.replace_robot("panda", panda, None)
        before = stored(store)
        free = os.statvfs(small_disk)
        filler = small_disk / "filler"
        filler.write_bytes(b"\0" * (free.f_bavail * free.f_frsize - 64 * 1024))
        with pytest.raises(DiskFull, match=f"the disk holding the store \\({small_disk}\\) is full"):
            store.replace_robot("pr2", pr2, PR2)
        with pytest.raises(DiskFull):
            store.update(" ".join(["INSERT DATA { GRAPH <urn:x:g> {", *(f'<urn:x:{i}> <urn:x:p> "{"o" * 1000}" .'
                                                                        for i in range(400)), "} }"]))
        assert stored(store) == before
        assert store.db.execute("PRAGMA integrity_check").fetchone() == ("ok",)
        filler.unlink()
        store.replace_robot("pr2", pr2, PR2)
        assert [e.name for e in store.robots()] == ["panda", "pr2"]
    finally:
        store.close()
