"""Writing a file atomically: a temporary file beside it, then a rename over the target, so a reader sees
the old file or the new one and never part of one; a crash leaves at most a stray `.*.tmp` beside it."""
from __future__ import annotations

import os
import tempfile
from pathlib import Path


def write_atomically(path: str | os.PathLike, *chunks: bytes | memoryview, sync: bool = True, mode: int | None = None) -> None:
    """Write `chunks` to `path` in one rename. `sync` flushes the data to disk before the rename (so a crash
    cannot leave an empty file under the new name); `mode` sets the permissions (else the temporary
    file's: 0600)."""
    target = Path(path).absolute()
    fd, tmp = tempfile.mkstemp(dir=target.parent, prefix=".", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as out:
            for chunk in chunks:
                out.write(chunk)
            if sync:
                out.flush()
                os.fsync(out.fileno())
        if mode is not None:
            os.chmod(tmp, mode)
        os.replace(tmp, target)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
