"""The model-layer contract: a question with a finite answer set, and the backend interface."""
from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import Sequence


@dataclass(frozen=True)
class Question:
    """One classification question; `system` is the shared (KV-cached) prefix, `options` the valid answers.

    `until_unique`: a backend that scores token by token may score each option only up to the token where
    it parts from every other option, the rest being forced (as constrained decoding forces it)."""

    system: str
    user: str
    options: tuple[str, ...]
    key: str = ""
    until_unique: bool = False

    def __post_init__(self) -> None:
        if not self.options:
            raise ValueError(f"question {self.key!r} has no options")
        if any(not o for o in self.options):
            raise ValueError(f"question {self.key!r} has an empty option")
        if len(set(self.options)) != len(self.options):
            raise ValueError(f"question {self.key!r} has duplicate options: {self.options}")


@dataclass
class Stats:
    """Work done by a backend."""

    calls: int = 0  # backend requests/decodes
    prompt_tokens: int = 0  # tokens evaluated (prompt + scored answer tokens)
    restored_tokens: int = 0  # prompt tokens whose KV state was loaded from disk instead of evaluated
    generated_tokens: int = 0


class Backend(ABC):
    """A language model that can score whole options and/or sample answers."""

    name: str
    exposes_logits: bool
    stats: Stats

    @abstractmethod
    def score(self, questions: Sequence[Question]) -> list[list[float]]:
        """Per question, the log-probability of each whole option (all its tokens, and end-of-turn where another option continues it), same order as options."""

    @abstractmethod
    def sample(self, question: Question, n: int, temperature: float) -> list[str]:
        """n completions, constrained to the options where the backend can; raw text otherwise."""

    def fresh(self) -> None:
        """Forget what earlier calls left (caches, counters): from here on, answer as a new backend would."""
        self.stats = Stats()

    def close(self) -> None:  # noqa: B027  (a default for every backend, not an abstract method)
        """Release the model; the default has nothing to release."""
