"""The Oracle: turns a backend into a constrained classifier by aggregating votes over valid options."""
from __future__ import annotations

import json
import math
import time
from dataclasses import dataclass
from typing import Sequence, TextIO

from urdfkb.pipeline.errors import BackendError
from urdfkb.pipeline.llm.base import Backend, Question, Stats
from urdfkb.settings import MAX_VOTES, RETRIES, TEMPERATURE, VOTES

MODES = ("exact", "sample")  # the values of core:votingMode


def check_voting(vote: str | None, votes: int) -> None:
    """ValueError unless `vote` is None (chosen by the backend) or one of MODES and 1 <= votes <= MAX_VOTES:
    the one check of voting settings (command line, POST /populate, Oracle)."""
    if vote not in (None, *MODES):
        raise ValueError(f"vote must be 'exact' or 'sample', not {vote!r}")
    if not 1 <= votes <= MAX_VOTES:
        raise ValueError(f"votes must be between 1 and {MAX_VOTES}, not {votes}")


@dataclass(frozen=True)
class Verdict:
    """An answer among the options (None = abstention), its share of the votes, and the full distribution."""

    answer: str | None
    confidence: float
    distribution: dict[str, float]


def normalise(text: object, options: Sequence[str]) -> str | None:
    """The option a raw answer names (stripped; exact, else unique case-insensitive match), or None."""
    if not isinstance(text, str):
        return None
    text = text.strip()
    if text in options:
        return text
    folded = [o for o in options if o.casefold() == text.casefold()]
    return folded[0] if len(folded) == 1 else None


def softmax(logprobs: Sequence[float]) -> list[float]:
    """Probabilities renormalised over the given log-probabilities."""
    top = max(logprobs)
    weights = [math.exp(lp - top) for lp in logprobs]
    total = sum(weights)
    return [w / total for w in weights]


def verdict(options: Sequence[str], shares: Sequence[float]) -> Verdict:
    """The plurality option (ties: the earlier one); no positive share means abstention."""
    distribution = dict(zip(options, shares))
    best = max(range(len(options)), key=lambda i: (shares[i], -i))
    if shares[best] <= 0:
        return Verdict(None, 0.0, distribution)
    return Verdict(options[best], shares[best], distribution)


class Oracle:
    """Asks a backend constrained questions and aggregates its votes into verdicts.

    vote="exact": softmax of whole-option log-probabilities (the infinite-vote limit; `votes`
    and `temperature` are unused). vote="sample": `votes` samples at `temperature`; an answer
    outside the options is re-asked up to `retries` times, then counted as an abstention.
    """

    def __init__(
        self,
        backend: Backend,
        vote: str | None = None,
        votes: int = VOTES,
        temperature: float = TEMPERATURE,
        retries: int = RETRIES,
        trace: TextIO | None = None,
    ):
        check_voting(vote, votes)
        vote = vote or ("exact" if backend.exposes_logits else "sample")
        if vote == "exact" and not backend.exposes_logits:
            raise BackendError(f"backend {backend.name} exposes no log-probabilities: use vote='sample'")
        if retries < 0 or temperature < 0:
            raise ValueError(f"need retries >= 0, temperature >= 0 (got {retries}, {temperature})")
        self.backend, self.vote, self.votes = backend, vote, votes
        self.temperature, self.retries, self.trace = temperature, retries, trace
        self.seconds = 0.0  # wall time inside the backend's calls (model work)

    @property
    def stats(self) -> Stats:
        """The backend's work counters."""
        return self.backend.stats

    def provenance(self) -> dict[str, str]:
        """Which model answered and how votes were taken (votes and temperature only when sampled)."""
        if self.vote == "exact":
            return {"model": self.backend.name, "vote": self.vote}
        return {"model": self.backend.name, "vote": self.vote, "votes": str(self.votes),
                "temperature": str(self.temperature)}

    def ask(self, questions: Sequence[Question]) -> list[Verdict]:
        """One verdict per question; any backend failure raises BackendError."""
        questions = list(questions)
        if not questions:
            return []
        verdicts = self._exact(questions) if self.vote == "exact" else [self._sample(q) for q in questions]
        for q, v in zip(questions, verdicts):
            self._write_trace(q, v)
        return verdicts

    def _call(self, what: str, fn, *args):
        started = time.perf_counter()
        try:
            return fn(*args)
        except BackendError:
            raise
        except Exception as exc:  # any backend failure becomes a BackendError
            raise BackendError(f"backend {self.backend.name} failed in {what}: {type(exc).__name__}: {exc}") from exc
        finally:
            self.seconds += time.perf_counter() - started

    def _exact(self, questions: list[Question]) -> list[Verdict]:
        rows = self._call("score", self.backend.score, questions)
        if not isinstance(rows, list) or len(rows) != len(questions):
            raise BackendError(f"backend {self.backend.name} returned scores for the wrong number of questions")
        return [verdict(q.options, softmax(self._check_row(q, row))) for q, row in zip(questions, rows)]

    def _check_row(self, question: Question, row: object) -> list[float]:
        try:
            values = [float(x) for x in row]  # type: ignore[attr-defined]  # any object: TypeError is caught
        except (TypeError, ValueError):
            values = []
        usable = len(values) == len(question.options) and not any(math.isnan(v) or v == math.inf for v in values)
        if not usable or max(values) == -math.inf:
            raise BackendError(f"backend {self.backend.name} returned unusable scores for {question.key or question.user!r}: {row!r}")
        return values

    def _sample(self, question: Question) -> Verdict:
        counts = dict.fromkeys(question.options, 0)
        pending = self.votes
        for _ in range(1 + self.retries):
            answers = self._draw(question, pending)
            valid = [a for a in (normalise(t, question.options) for t in answers) if a is not None]
            for answer in valid:
                counts[answer] += 1
            pending -= len(valid)
            if pending == 0:
                break
        return verdict(question.options, [counts[o] / self.votes for o in question.options])

    def _draw(self, question: Question, n: int) -> list:
        answers = self._call("sample", self.backend.sample, question, n, self.temperature)
        if not isinstance(answers, list):
            raise BackendError(f"backend {self.backend.name} sample returned {type(answers).__name__}, not a list")
        return answers[:n]

    def _write_trace(self, question: Question, v: Verdict) -> None:
        if self.trace is None:
            return
        record = {
            "key": question.key,
            "options": list(question.options),
            "distribution": v.distribution,
            "answer": v.answer,
            "confidence": v.confidence,
            "mode": self.vote,
        }
        self.trace.write(json.dumps(record) + "\n")
        self.trace.flush()
