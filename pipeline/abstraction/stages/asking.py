"""Asking batches of questions with progress reporting."""
from __future__ import annotations

from typing import Callable, Sequence

from urdfkb.pipeline.llm.base import Question
from urdfkb.pipeline.abstraction.oracle import Oracle, Verdict

Progress = Callable[[str, int, int], None]
CHUNK = 8  # questions per backend call: large enough to batch, small enough to show progress


def ask(oracle: Oracle, questions: Sequence[Question], stage: str, progress: Progress | None) -> list[Verdict]:
    """Verdicts for all questions, sorted by shared system text for KV reuse, in input order."""
    order = sorted(range(len(questions)), key=lambda i: questions[i].system)
    verdicts: list[Verdict | None] = [None] * len(questions)
    done = 0
    if progress:
        progress(stage, 0, len(questions))
    for start in range(0, len(order), CHUNK):
        chunk = order[start:start + CHUNK]
        for i, v in zip(chunk, oracle.ask([questions[i] for i in chunk])):
            verdicts[i] = v
        done += len(chunk)
        if progress:
            progress(stage, done, len(questions))
    return verdicts  # type: ignore[return-value]
