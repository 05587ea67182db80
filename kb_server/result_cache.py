"""Finished SPARQL answers, kept until the next write: a query asked again is answered without a worker.

An answer is kept under everything it depends on: the query text, the Accept header it was negotiated
for, the protocol's dataset (default-graph-uri, named-graph-uri) and the generation of the index's data.
The index (kb_server/index.py) calls `invalidate` once every write it applies has reached the master and
every worker, which moves to the next generation and drops every answer kept; `put` keeps an answer only
if no write came between the query's submission (when it took the generation) and its answer, so a query
submitted after a write returned never gets an answer computed before it.

Never kept: errors and timeouts (only answers are given to `put`), answers over a sixteenth of the cache,
queries the lexical checks refuse (so a refused query never reaches a lookup, let alone hits) and queries
calling a function whose value changes from one call to the next (SPARQL 1.1, section 17.4: NOW, RAND,
UUID, STRUUID, BNODE). The bound is on bytes (the answers' bodies and their keys), least recently used
out first; a capacity of 0 keeps nothing.
"""
from __future__ import annotations

import threading
from collections import OrderedDict

from urdfkb.kb_server.sparql import QueryError, Result, scan

VOLATILE = frozenset({"NOW", "RAND", "UUID", "STRUUID", "BNODE"})  # keywords (functions) answered anew each call
Key = tuple[str, str | None, tuple[str, ...] | None, tuple[str, ...] | None]


def cache_key(text: str, accept: str | None, default_graphs: list[str] | None, named_graphs: list[str] | None) -> Key | None:
    """The key a query's answer is kept under; None for a query whose answer is never kept (refused by the
    lexical checks, or calling a VOLATILE function)."""
    try:
        found = scan(text)
    except QueryError:  # the worker refuses it, as without a cache
        return None
    if found.keywords & VOLATILE:
        return None
    return (text, accept, None if default_graphs is None else tuple(default_graphs),
            None if named_graphs is None else tuple(named_graphs))


def no_cache(cache_control: str | None) -> bool:
    """True when a request's Cache-Control header has the no-cache directive (RFC 9111, 5.2.1.4: no answer
    from a cache without asking the origin): the query is evaluated, and its answer kept again."""
    return any(d.partition("=")[0].strip().lower() == "no-cache" for d in (cache_control or "").split(","))


def _size(k: Key, result: Result) -> int:
    text, accept, default, named = k
    return len(result.body) + len(text) + len(accept or "") + sum(map(len, (*(default or ()), *(named or ()))))


class ResultCache:
    """At most `capacity` bytes of answers (0: none), least recently used out first; safe to share between threads."""

    def __init__(self, capacity: int):
        if capacity < 0:
            raise ValueError(f"the result cache's capacity must be 0 or more bytes, not {capacity}")
        self.capacity, self.largest = capacity, capacity // 16
        self.generation = 0  # of the index's data; read without the lock (an int), compared under it
        self._lock = threading.Lock()
        self._kept: OrderedDict[Key, tuple[Result, int]] = OrderedDict()  # key -> (answer, its size)
        self.bytes = 0

    def get(self, k: Key) -> Result | None:
        """The answer kept under `k` (a Result of its own), None if none is."""
        with self._lock:
            entry = self._kept.get(k)
            if entry is None:
                return None
            self._kept.move_to_end(k)
        result = entry[0]
        return Result(result.kind, result.media_type, result.body)

    def put(self, k: Key, generation: int, result: Result) -> None:
        """Keep `result` under `k` if the data are still those of `generation` (taken before the query was
        submitted) and it is at most `largest` bytes; drop the least recently used answers past `capacity`."""
        size = _size(k, result)
        if size > self.largest:
            return
        with self._lock:
            if generation != self.generation:
                return
            old = self._kept.pop(k, None)
            self.bytes += size - (old[1] if old else 0)
            self._kept[k] = (Result(result.kind, result.media_type, result.body), size)
            while self.bytes > self.capacity:
                _, (_, dropped) = self._kept.popitem(last=False)
                self.bytes -= dropped

    def invalidate(self) -> None:
        """(After a write has reached the data every query reads) the next generation; every answer kept is dropped."""
        with self._lock:
            self.generation += 1
            self._kept.clear()
            self.bytes = 0

    def __len__(self) -> int:
        return len(self._kept)
