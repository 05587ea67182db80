"""A persistent on-disk cache of the KV states of static prompt prefixes, one file per prefix.

The backend evaluates every prefix into an emptied KV cache (pipeline.llm.llama), so a state is a
function of its tokens and of the identity it was computed under (model file, llama.cpp build,
context parameters) alone: both go into its file's name, and its header repeats that key with the
payload's length and sha256. Anything that does not check out is logged and ignored (the caller evaluates the
prefix instead); writes are atomic; the directory is kept under a size bound by deleting the least
recently used files.
"""
from __future__ import annotations

import hashlib
import json
import logging
import os
import struct
import time
from pathlib import Path
from typing import Sequence

from urdfkb.pipeline.atomic import write_atomically
from urdfkb.pipeline.cache import cache_root
from urdfkb.settings import PREFIX_CACHE_BYTES

log = logging.getLogger(__name__)

MAGIC = b"URDFKB-KV\x00"
FORMAT = 3  # 3: keyed by tokens alone (every state is computed in an emptied cache)
_HEADER = struct.Struct("<I Q 32s 32s")  # format, payload length, sha256(payload), key digest
SUFFIX = ".kv"
SUBDIR = "prefixes"
# "off" / "0" / "false" / "no" disables the store; it is on otherwise. A state is restored into the
# emptied cache it was computed in, the cells evaluating it would fill, so it changes no score.
ENV_SWITCH = "URDFKB_PREFIX_CACHE"


def default_dir() -> Path:
    """cache_root()/prefixes: beside the result cache and the models."""
    return cache_root() / SUBDIR


def enabled_by_env() -> bool:
    return os.environ.get(ENV_SWITCH, "on").strip().lower() not in ("0", "off", "false", "no")


class PrefixStore:
    """KV-state payloads (opaque bytes) keyed by an identity and a token sequence: a file holds the
    state of positions 0..len(tokens)-1, computed from an empty cache."""

    def __init__(self, directory: Path, identity: dict, max_bytes: int = PREFIX_CACHE_BYTES):
        self.directory = Path(directory)
        self.identity = json.dumps(identity, sort_keys=True)
        self.max_bytes = max_bytes
        self.hits = self.writes = self.rejected = 0

    def _key(self, tokens: Sequence[int]) -> bytes:
        return hashlib.sha256(json.dumps([FORMAT, self.identity, list(tokens)]).encode()).digest()

    def path(self, tokens: Sequence[int]) -> Path:
        return self.directory / f"{self._key(tokens).hex()}{SUFFIX}"

    def load(self, tokens: Sequence[int]) -> memoryview | None:
        """The stored payload, or None when absent, unreadable, corrupt or mismatched."""
        path, key = self.path(tokens), self._key(tokens)
        try:
            blob = bytearray(path.read_bytes())
        except FileNotFoundError:
            return None
        except OSError as exc:
            self._reject(path, f"unreadable ({exc})")
            return None
        head = len(MAGIC) + _HEADER.size
        if len(blob) < head or blob[:len(MAGIC)] != MAGIC:
            self._reject(path, "not a prefix-state file")
            return None
        fmt, size, digest, stored_key = _HEADER.unpack_from(blob, len(MAGIC))
        payload = memoryview(blob)[head:]
        if fmt != FORMAT or stored_key != key:
            self._reject(path, "written for another format or key")
            return None
        if len(payload) != size or hashlib.sha256(payload).digest() != digest:
            self._reject(path, f"corrupt ({len(payload)} of {size} bytes, or checksum mismatch)")
            return None
        try:
            os.utime(path)  # least recently used goes first
        except OSError:
            pass
        self.hits += 1
        return payload

    def discard(self, tokens: Sequence[int], reason: str) -> None:
        """Drop a file the backend could not restore."""
        self._reject(self.path(tokens), reason)

    def _reject(self, path: Path, reason: str) -> None:
        self.rejected += 1
        log.warning("urdfkb: ignoring cached prompt state %s: %s; evaluating the prompt instead", path, reason)
        try:
            path.unlink(missing_ok=True)
        except OSError:
            pass
        return None

    def save(self, tokens: Sequence[int], payload: bytes | memoryview) -> None:
        """Store atomically (temporary file, then rename), then evict beyond the size bound.

        A failure to write is logged, never raised: the cache only saves time.
        """
        key = self._key(tokens)
        header = MAGIC + _HEADER.pack(FORMAT, len(payload), hashlib.sha256(payload).digest(), key)
        target = self.path(tokens)
        try:
            self.directory.mkdir(parents=True, exist_ok=True)
            write_atomically(target, header, payload, sync=False)  # a torn file fails its checksum on load
        except OSError as exc:
            log.warning("urdfkb: cannot write cached prompt state to %s: %s", self.directory, exc)
            return
        self.writes += 1
        self._evict(keep=target)

    def _evict(self, keep: Path) -> None:
        """Delete least recently used files until the directory fits max_bytes (never `keep`), and
        temporary files a killed writer left behind over an hour ago."""
        stale = time.time() - 3600
        for path in self.directory.glob(".*.tmp"):
            try:
                if path.stat().st_mtime < stale:
                    path.unlink()
            except OSError:
                pass
        entries = []
        for path in self.directory.glob("*" + SUFFIX):
            try:
                st = path.stat()
            except OSError:
                continue
            entries.append((st.st_mtime_ns, st.st_size, path))
        total = sum(size for _, size, _ in entries)
        for _, size, path in sorted(entries):
            if total <= self.max_bytes:
                break
            if path == keep:
                continue
            try:
                path.unlink()
                total -= size
            except OSError:
                pass
