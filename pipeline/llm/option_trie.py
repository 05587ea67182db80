"""Scoring a question's options with llama.cpp: the options as a token trie (the batch rows they need, the steps
each is scored on), and log-probabilities read from a batch row's logits."""
from __future__ import annotations

import math
import random
from dataclasses import dataclass
from types import ModuleType
from typing import TYPE_CHECKING, Callable, Sequence, TypeVar

import numpy as np

if TYPE_CHECKING:
    from llama_cpp import llama_context_p


@dataclass
class OptionJob:
    """One question prepared for scoring: its suffix after the shared prefix and its options' tokens.

    An option is scored as the sum of log P(token | before) over its tokens, and over the end-of-turn
    token only where that is a choice: where the option is a proper prefix of another one. Elsewhere the
    options themselves force the end, as they would force it in constrained decoding, and the end-of-turn
    row of every option no other one continues is spared.
    """

    suffix: list[int]
    options: list[list[int]]

    def trie(self) -> dict[tuple[int, ...], list[int]]:
        """Every row the options need (a non-empty proper prefix of some option, the context of its next
        token) → the indices of the options that start with it.

        Options sharing leading tokens share those batch entries (a token may belong to several
        sequences), so each distinct prefix is evaluated once. A prefix always comes after its parent.
        """
        inner = {tuple(o[:k]) for o in self.options for k in range(1, len(o))}
        nodes: dict[tuple[int, ...], list[int]] = {}
        for i, option in enumerate(self.options):
            for k in range(1, len(option) + 1):
                if tuple(option[:k]) in inner:
                    nodes.setdefault(tuple(option[:k]), []).append(i)
        return nodes

    def steps(self, option: list[int]) -> range:
        """The steps k scored for `option`: P(target k | the option's first k tokens), targets being its
        tokens and then end-of-turn (step len(option)) where another option continues it."""
        ends = any(len(o) > len(option) and o[:len(option)] == option for o in self.options)
        return range(len(option) + ends)

    @property
    def size(self) -> int:
        return len(self.suffix) + len(self.trie())


class RowLogprobs:
    """log P(token) read in place from the logits of one batch row (valid until the next decode);
    each row's normaliser is computed once."""

    def __init__(self, lib: ModuleType, ctx: llama_context_p, n_vocab: int):
        self.lib, self.ctx, self.n_vocab = lib, ctx, n_vocab
        self.rows: dict[int, tuple[np.ndarray, float]] = {}

    def __call__(self, row: int, token: int) -> float:
        if row not in self.rows:
            ptr = self.lib.llama_get_logits_ith(self.ctx, row)
            logits = np.ctypeslib.as_array(ptr, shape=(self.n_vocab,))
            top = float(logits.max())
            self.rows[row] = (logits, top + float(np.log(np.exp(logits - top).sum(dtype=np.float64))))
        logits, logz = self.rows[row]
        return float(logits[token]) - logz


Row = TypeVar("Row")  # what names a batch row: its index, or anything a stand-in reads log-probabilities by


def draw(targets: Sequence[Sequence[int]], rows: Sequence[Sequence[tuple[int, Row]]],
         logprobs: Callable[[Row, int], float], temperature: float, rng: random.Random) -> int:
    """One walk down the option trie; returns the index of the option it ends in. `targets` are the options'
    tokens then end-of-turn, `rows` each option's scored steps with the row predicting each (OptionJob.steps).
    Only where the options part ways is there a choice (and a row to read): the rest is forced by the options.
    A step picks the likeliest token at temperature 0, else draws from a softmax at `temperature` over the
    tokens that continue some option. Options that tokenize alike never part ways; the walk ends in the first."""
    alive, step = list(range(len(targets))), 0
    while len(alive) > 1 and step < len(targets[alive[0]]):
        branches: dict[int, list[int]] = {}
        for i in alive:
            branches.setdefault(targets[i][step], []).append(i)
        tokens = list(branches)
        if len(tokens) > 1:
            row = dict(rows[alive[0]])[step]
            scores = [logprobs(row, t) for t in tokens]
            if temperature <= 0:
                pick = max(range(len(tokens)), key=scores.__getitem__)
            else:
                top = max(scores)
                pick = rng.choices(range(len(tokens)), [math.exp((x - top) / temperature) for x in scores])[0]
            alive = branches[tokens[pick]]
        step += 1
    return alive[0]


def unique_length(option: list[int], options: list[list[int]]) -> int:
    """The tokens of `option` up to the first that no other option shares at that place (all, if none)."""
    return max((common_prefix(option, o) + 1 for o in options if o is not option), default=1)


def common_prefix(a: Sequence[int], b: Sequence[int]) -> int:
    n = 0
    for x, y in zip(a, b):
        if x != y:
            break
        n += 1
    return n
