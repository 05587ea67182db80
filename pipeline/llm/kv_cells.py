"""A mirror of llama.cpp's bookkeeping of its unified KV cache, so the backend knows which cell holds what.

llama.cpp's CPU kernels are exact functions of the cells a token attends over: the same values in
the same cells give bit-identical scores, other cells give other roundings. The backend keeps this
mirror in step with every operation it makes on the cache (a decode, `seq_rm`, `seq_cp`, clearing
it, restoring a sequence's state), following llama-kv-cache.cpp of the llama.cpp that
llama-cpp-python 0.3.36 vendors (one stream: `kv_unified`; no sliding window), so it can predict the
cells the next decode or restore will use, and name what each cell holds by a content digest: what
computed it (its tokens, positions and cells, and the digests of the cells it attended over). A
stored prompt state is then restored only where it lands in the cells, with the same contents
around it, that evaluating the prompt would have given (pipeline.llm.llama), which makes a restore
bit-identical to evaluating. tests/test_llama_integration.py checks the mirror against llama.cpp's
own debug dump of its cells (LLAMA_KV_CACHE_DEBUG).
"""
from __future__ import annotations

from collections.abc import Iterable, Sequence


class KVCells:
    """Cells 0..size-1: each empty (position -1) or holding one position of one or more sequences."""

    def __init__(self, size: int):
        self.size = size
        self.clear()

    def clear(self) -> None:
        """llama_kv_cache::clear: every cell empty, head at 0."""
        self.pos = [-1] * self.size
        self.seqs: list[set[int]] = [set() for _ in range(self.size)]
        self.content: list[bytes | None] = [None] * self.size
        self.cells_of: dict[int, set[int]] = {}  # sequence -> the cells holding it
        self.used = 0
        self.head = 0

    # --- placement ----------------------------------------------------------------------------

    def find(self, n: int, taken: Iterable[int] = ()) -> list[int]:
        """The cells find_slot(ubatch of n tokens, cont=false) picks: free cells from `head` on, wrapping
        around, unless head is past used + 2n (then from 0). `taken` cells count as occupied (a
        placement being simulated)."""
        busy = set(taken)
        head = self.head
        if head > self.used + len(busy) + 2 * n:
            head = 0
        found: list[int] = []
        tested = 0
        while True:
            if head + 1 > self.size:
                tested += self.size - head
                head = 0
                continue
            idx, head, tested = head, head + 1, tested + 1
            if self.pos[idx] == -1 and idx not in busy:
                found.append(idx)
            if len(found) == n:
                return found
            if tested >= self.size:
                raise ValueError(f"no room for {n} tokens in a KV cache of {self.size} cells ({self.used} used)")

    def chunks(self, sizes: Sequence[int]) -> list[list[int]]:
        """The cells successive decodes of `sizes` tokens would take (nothing freed between them)."""
        taken: list[int] = []
        out = []
        head, used = self.head, self.used
        for n in sizes:
            cells = self.find(n, taken)
            out.append(cells)
            taken += cells
            self.head = cells[-1] + 1  # as apply() would move it
        self.head, self.used = head, used
        return out

    def apply(self, cells: Sequence[int], entries: Sequence[tuple[int, Iterable[int]]],
              contents: Sequence[bytes | None]) -> None:
        """apply_ubatch: cell i takes (position, sequences) of entry i; head moves past the last cell."""
        for idx, (position, seqs), content in zip(cells, entries, contents, strict=True):
            if self.pos[idx] != -1:
                raise ValueError(f"cell {idx} is not free")
            self.pos[idx], self.content[idx] = position, content
            self.used += 1
            for seq in seqs:
                self.seqs[idx].add(seq)
                self.cells_of.setdefault(seq, set()).add(idx)
        if cells:
            self.head = cells[-1] + 1

    def restore(self, seq: int, positions: Sequence[int], contents: Sequence[bytes | None]) -> list[int]:
        """state_read_meta for one sequence: its cells emptied, then the state's cells placed as one ubatch."""
        self.seq_rm(seq)
        cells = self.find(len(positions))
        self.apply(cells, [(p, (seq,)) for p in positions], contents)
        return cells

    # --- sequences ----------------------------------------------------------------------------

    def seq_rm(self, seq: int, p0: int = -1, p1: int = -1) -> None:
        """llama_kv_cache::seq_rm for one sequence: positions [p0, p1) leave it; cells left empty are
        freed, and head moves back to the first of them if it is lower."""
        p0 = max(p0, 0)
        p1 = p1 if p1 >= 0 else 1 << 62
        freed = self.size
        held = self.cells_of.get(seq, set())
        for idx in sorted(held):
            if not p0 <= self.pos[idx] < p1:
                continue
            held.discard(idx)
            self.seqs[idx].discard(seq)
            if not self.seqs[idx]:
                self.pos[idx], self.content[idx] = -1, None
                self.used -= 1
                freed = min(freed, idx)
        if freed < self.head:
            self.head = freed

    def seq_cp(self, src: int, dst: int, p0: int = -1, p1: int = -1) -> None:
        """llama_kv_cache::seq_cp within the one stream: cells of `src` in [p0, p1) also hold `dst`."""
        p0 = max(p0, 0)
        p1 = p1 if p1 >= 0 else 1 << 62
        if src == dst:
            return
        for idx in self.cells_of.get(src, set()):
            if p0 <= self.pos[idx] < p1:
                self.seqs[idx].add(dst)
                self.cells_of.setdefault(dst, set()).add(idx)

    def layout(self, seq: int) -> list[tuple[int, int, bytes | None]]:
        """(position, cell, content) of every cell holding `seq`, by position."""
        return sorted((self.pos[idx], idx, self.content[idx]) for idx in self.cells_of.get(seq, ()))

    def dump_positions(self) -> str:
        """The positions map LLAMA_KV_CACHE_DEBUG=3 prints after the cell map."""
        out = []
        for idx in range(self.size):
            out.append(f"{'.' if self.pos[idx] == -1 else self.pos[idx]:<5}")
            if idx % 256 == 255:
                out.append(" *")
            if idx % 64 == 63:
                out.append("\n")
        return "".join(out)

    def dump(self) -> str:
        """The cell map as LLAMA_KV_CACHE_DEBUG=3 prints it: '.' empty, the sequence of a cell with one,
        'M' for several; ' *' and a newline after every 256 cells."""
        out = []
        for idx in range(self.size):
            seqs = self.seqs[idx]
            out.append("." if self.pos[idx] == -1 else str(next(iter(seqs))) if len(seqs) == 1 else "M")
            if idx % 256 == 255:
                out.append(" *\n")
        return "".join(out)
