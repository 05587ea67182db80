"""Bounded serialisation of query answers: at most `rows` rows and `bytes` bytes, checked as they are written.

A SELECT answer is written by Oxigraph's own writer into `_Sink`, which keeps the bytes, counts the rows
going by (by the bytes that open one, outside quoted strings) and raises ResultTooLarge as soon as either
cap is passed, which stops the writer and the lazy evaluation feeding it: an oversized body is never built.
A CONSTRUCT or DESCRIBE answer reaches the writer through `_capped`, which counts its triples.
"""
from __future__ import annotations

from dataclasses import dataclass

import pyoxigraph as ox

from urdfkb.pipeline.errors import UrdfkbError
from urdfkb.settings import MAX_RESULT_BYTES, MAX_RESULT_ROWS, QUERY_MEMORY

MIN_QUERY_MEMORY = 256 * 2**20
_PAGING = "add a LIMIT, or page through the answer with LIMIT and OFFSET (and ORDER BY, for stable pages)"

# Per results format: the bytes that open a row, whether they may sit in "quoted" strings, whether those use
# backslash escapes, and the header lines before the rows. TSV and XML escape newlines and "<" in values.
_ROWS: dict[ox.QueryResultsFormat | ox.RdfFormat, tuple[tuple[bytes, ...], bool, bool, int]] = {
    ox.QueryResultsFormat.JSON: ((b"[{", b",{"), True, True, 0),
    ox.QueryResultsFormat.XML: ((b"<result>",), False, False, 0),
    ox.QueryResultsFormat.CSV: ((b"\n",), True, False, 1),
    ox.QueryResultsFormat.TSV: ((b"\n",), False, False, 1),
}


class ResultTooLarge(UrdfkbError, RuntimeError):
    """The answer has more rows or bytes than the server's limits; the message names the limit and its value."""

    status = 413


@dataclass(frozen=True)
class ResultLimits:
    """What one query may cost: `rows` solutions (or triples) and `bytes` serialised bytes in its answer, and
    `memory` bytes of address space for the worker process evaluating it (kb_server/index.py)."""

    rows: int = MAX_RESULT_ROWS
    bytes: int = MAX_RESULT_BYTES
    memory: int = QUERY_MEMORY

    def __post_init__(self) -> None:
        if self.rows < 1 or self.bytes < 1:
            raise UrdfkbError(f"result limits must be positive (max-result-rows {self.rows}, max-result-bytes {self.bytes})")
        if self.memory < MIN_QUERY_MEMORY:
            raise UrdfkbError(f"--query-memory must be at least {MIN_QUERY_MEMORY // 2**20} MiB (a worker's Python and "
                              f"its copy of the store), not {self.memory // 2**20} MiB")

    def too_many(self, what: str = "rows") -> ResultTooLarge:
        return ResultTooLarge(f"the answer has more than {self.rows:,} {what}, the server's limit "
                              f"(max-result-rows): {_PAGING}")

    def too_big(self) -> ResultTooLarge:
        return ResultTooLarge(f"the answer is larger than {self.bytes:,} bytes, the server's limit "
                              f"(max-result-bytes): {_PAGING}")


def serialize(answer: ox.QuerySolutions | ox.QueryTriples | ox.QueryBoolean, fmt: ox.QueryResultsFormat | ox.RdfFormat,
              limits: ResultLimits) -> bytes:
    """`answer` written in `fmt` (a QueryResultsFormat or RdfFormat); ResultTooLarge past `limits`."""
    # pyoxigraph's stubs type `output` as typing.IO[bytes], but its writers only call write() and flush()
    if isinstance(answer, ox.QueryTriples):
        sink = _Sink(limits)
        ox.serialize(_capped(answer, limits), sink, fmt)  # type: ignore[arg-type]
    else:
        sink = _Sink(limits, *_ROWS[fmt]) if isinstance(answer, ox.QuerySolutions) else _Sink(limits)
        answer.serialize(sink, fmt)  # type: ignore[arg-type]
    return bytes(sink.body)


def _capped(triples: ox.QueryTriples, limits: ResultLimits):
    for n, triple in enumerate(triples, 1):
        if n > limits.rows:
            raise limits.too_many("triples")
        yield triple


class _Sink:
    """A binary file pyoxigraph writes into (in chunks of about 8 KB): keeps them, counts the rows they open."""

    def __init__(self, limits: ResultLimits, marks: tuple[bytes, ...] = (), quoted: bool = False,
                 escapes: bool = False, header: int = 0):
        self.limits, self.marks, self.quoted, self.escapes = limits, marks, quoted, escapes
        self.body = bytearray()
        self.rows = -header
        self.inside = False  # within a quoted string where the last chunk ended
        self.carry = b""  # backslashes that ended the last chunk: their escape ends in the next one
        self.tail = b""  # the last chunk's final unquoted bytes, which may begin a mark
        self.keep = max((len(m) for m in marks), default=1) - 1

    def write(self, data: bytes) -> int:
        if len(self.body) + len(data) > self.limits.bytes:
            raise self.limits.too_big()
        self.body += data
        if self.marks:
            self.rows += self._count(data)
            if self.rows > self.limits.rows:
                raise self.limits.too_many()
        return len(data)

    def flush(self) -> None:
        pass

    def _count(self, data: bytes) -> int:
        """Marks opened in `data`, outside quoted strings, with what the previous chunks left open."""
        if self.escapes:
            data = self.carry + data
            end = len(data.rstrip(b"\\"))
            data, self.carry = data[:end], data[end:]
            data = data.replace(b"\\\\", b"").replace(b'\\"', b"")  # every quote left delimits a string
        if self.quoted:
            parts = data.split(b'"')
            data = b"\0".join(parts[self.inside::2])  # the unquoted parts, never joined into a false mark
            self.inside ^= len(parts) % 2 == 0
        data = self.tail + data
        self.tail = b"" if self.inside else data[len(data) - self.keep:]
        return sum(data.count(m) for m in self.marks)
