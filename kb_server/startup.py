"""What `urdfkb serve` checks as it starts: the port, the store file, the listening socket. Each failure is a
UrdfkbError of one line naming the cause and the fix (the command prints it, without a traceback), found
before the store is opened where it can be."""
from __future__ import annotations

import errno
import sqlite3
from pathlib import Path

from urdfkb.kb_server.store import default_store_path
from urdfkb.pipeline.errors import UrdfkbError

MAX_PORT = 65_535


def check_port(port: int) -> None:
    """UrdfkbError unless `port` is a TCP port (0: any free one); the socket layer took 99999 as 34463."""
    if not 0 <= port <= MAX_PORT:
        raise UrdfkbError(f"--port {port} is not a TCP port: give one from 1 to {MAX_PORT:,} (0: any free port)")


def check_store(path: str | Path | None) -> Path:
    """The store's path (the default one for None), once it is known to be a store this user can write, or a
    file or folder where one can be made; UrdfkbError naming what is wrong and what to do otherwise. The
    check is one write transaction, rolled back: it changes nothing in an existing store."""
    store = Path(path) if path else default_store_path()
    if store.is_dir():
        raise UrdfkbError(f"the store {store} is a folder: give --store a file (e.g. {store / 'kb.sqlite3'})")
    try:
        store.parent.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise UrdfkbError(f"cannot make the store's folder {store.parent}: {e.strerror}: give --store a path "
                          "in a folder this user can write") from None
    try:
        db = sqlite3.connect(store, isolation_level=None)
    except sqlite3.Error as e:
        raise _store_error(store, e) from None
    try:
        db.execute("BEGIN IMMEDIATE")
        db.execute("CREATE TABLE urdfkb_write_check (x)")  # rolled back: proves a write without making one
        db.execute("ROLLBACK")
    except sqlite3.Error as e:
        raise _store_error(store, e) from None
    finally:
        db.close()
    return store


def _store_error(store: Path, e: sqlite3.Error) -> UrdfkbError:
    text = str(e)
    if "not a database" in text:
        return UrdfkbError(f"{store} is not a urdfkb store (SQLite: {text}): give --store a store file, or the "
                           "path of a new one")
    if "readonly" in text:
        return UrdfkbError(f"the store {store} is read-only for this user: make it writable (chmod u+w), or give "
                           "--store another path")
    if "unable to open" in text:
        return UrdfkbError(f"cannot open or create the store {store}: its folder {store.parent} is not writable by "
                           "this user: make it writable, or give --store a path in a writable folder")
    if "locked" in text:
        return UrdfkbError(f"the store {store} is locked by another process (another urdfkb serve?): stop it, "
                           "or give --store another path")
    return UrdfkbError(f"cannot use the store {store}: SQLite: {text}: give --store another path")


def listen_error(host: str, port: int, e: OSError) -> UrdfkbError:
    """The one-line refusal for a socket that cannot listen on `host`:`port`."""
    if e.errno == errno.EADDRINUSE:
        return UrdfkbError(f"port {port} on {host} is in use (another urdfkb serve?): stop that server, or give "
                           "another --port")
    if e.errno == errno.EACCES:
        return UrdfkbError(f"this user may not listen on port {port}: give a --port above 1023")
    if e.errno == errno.EADDRNOTAVAIL:
        return UrdfkbError(f"--host {host} is not an address of this machine: give one of its addresses, or "
                           "0.0.0.0 for all")
    return UrdfkbError(f"cannot listen on {host}:{port}: {e.strerror or e}: check --host and --port")
