"""A persistent on-disk cache of the KV states of static prompt prefixes, one file per prefix and layout.

A file is valid only for the identity it was written under (model file, llama.cpp build, context
parameters), the exact prefix tokens, the split (the leading tokens whose state is not in the
file: those the slot already held when the rest was evaluated) and the layout (a digest of the KV
cells the state went to and of the cells, with their contents, it was computed next to: see
pipeline.llm.llama): all go into its name, and its header repeats that key with the payload's
length and sha256. Anything that does not check out is logged and ignored (the caller evaluates the
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

log = logging.getLogger(__name__)

MAGIC = b"URDFKB-KV\x00"
FORMAT = 2  # 2: keyed by layout too
_HEADER = struct.Struct("<I Q 32s 32s")  # format, payload length, sha256(payload), key digest
SUFFIX = ".kv"
SUBDIR = "prefixes"
DEFAULT_MAX_BYTES = 256 << 20
# "off" / "0" / "false" / "no" disables the store; it is on otherwise. A state is restored only into the
# KV cells evaluating it would have filled, next to the same contents, so it changes no score.
ENV_SWITCH = "URDFKB_PREFIX_CACHE"


def default_dir() -> Path:
    """cache_root()/prefixes: beside the result cache and the models."""
    return cache_root() / SUBDIR


def enabled_by_env() -> bool:
    return os.environ.get(ENV_SWITCH, "on").strip().lower() not in ("0", "off", "false", "no")


class PrefixStore:
    """KV-state payloads (opaque bytes) keyed by an identity, a token sequence, a split and a layout: a
    file holds the state of positions split..len(tokens)-1, computed after tokens[:split] in the
    cells `layout` names."""

    def __init__(self, directory: Path, identity: dict, max_bytes: int = DEFAULT_MAX_BYTES):
        self.directory = Path(directory)
        self.identity = json.dumps(identity, sort_keys=True)
        self.max_bytes = max_bytes
        self.hits = self.writes = self.rejected = 0

    def _stem(self, tokens: Sequence[int]) -> str:
        return hashlib.sha256(json.dumps([FORMAT, self.identity, list(tokens)]).encode()).hexdigest()

    def _key(self, tokens: Sequence[int], split: int, layout: str) -> bytes:
        return hashlib.sha256(f"{self._stem(tokens)}-{split}-{layout}".encode()).digest()

    def path(self, tokens: Sequence[int], split: int, layout: str) -> Path:
        return self.directory / f"{self._key(tokens, split, layout).hex()}{SUFFIX}"

    def load(self, tokens: Sequence[int], split: int, layout: str) -> memoryview | None:
        """The stored payload, or None when absent, unreadable, corrupt or mismatched."""
        path, key = self.path(tokens, split, layout), self._key(tokens, split, layout)
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

    def discard(self, tokens: Sequence[int], split: int, layout: str, reason: str) -> None:
        """Drop a file the backend could not restore."""
        self._reject(self.path(tokens, split, layout), reason)

    def _reject(self, path: Path, reason: str) -> None:
        self.rejected += 1
        log.warning("urdfkb: ignoring cached prompt state %s: %s; evaluating the prompt instead", path, reason)
        try:
            path.unlink(missing_ok=True)
        except OSError:
            pass
        return None

    def save(self, tokens: Sequence[int], split: int, layout: str, payload: bytes | memoryview) -> None:
        """Store atomically (temporary file, then rename), then evict beyond the size bound.

        A failure to write is logged, never raised: the cache only saves time.
        """
        key = self._key(tokens, split, layout)
        header = MAGIC + _HEADER.pack(FORMAT, len(payload), hashlib.sha256(payload).digest(), key)
        target = self.path(tokens, split, layout)
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
