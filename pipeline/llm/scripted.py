"""A deterministic backend driven by a Python rule, for tests."""
from __future__ import annotations

import math
import random
from typing import Callable, Sequence

from urdfkb.pipeline.llm.base import Backend, Question, Stats

Rule = Callable[[Question], "str | dict[str, float]"]
EPSILON = 1e-9


class ScriptedBackend(Backend):
    """Answers by `rule`: a str means probability 1 for that option, a dict gives probabilities.

    A rule may raise, or name an answer outside the options: `sample` then returns it as raw
    text and `score` ignores it (the Oracle has to cope, as with a real model).
    """

    exposes_logits = True

    def __init__(self, rule: Rule, name: str = "scripted", seed: int = 0):
        self.rule = rule
        self.name = name
        self.stats = Stats()
        self.seed = seed
        self._rng = random.Random(seed)

    def fresh(self) -> None:
        super().fresh()
        self._rng = random.Random(self.seed)

    def _distribution(self, question: Question) -> dict[str, float]:
        self.stats.calls += 1
        out = self.rule(question)
        return {out: 1.0} if isinstance(out, str) else dict(out)

    def score(self, questions: Sequence[Question]) -> list[list[float]]:
        """Log of the rule's probability per option (EPSILON for options it leaves out)."""
        result = []
        for q in questions:
            dist = self._distribution(q)
            result.append([math.log(max(dist.get(o, 0.0), EPSILON)) for o in q.options])
        return result

    def sample(self, question: Question, n: int, temperature: float) -> list[str]:
        """n seeded draws, asking the rule once per draw (any answers it names, valid or not)."""
        return [self._draw(self._distribution(question)) for _ in range(n)]

    def _draw(self, dist: dict[str, float]) -> str:
        return self._rng.choices(list(dist), weights=list(dist.values()))[0]
