"""Stages 3 and 5, pre- and post-classification, and sub-part typing: descents of the taxonomy.

Each subject starts at a concept and goes down one level per question, choosing among the direct
subclasses the ontology offers, until it reaches a leaf concept (or stops at a concept whose lone
subclass the model declines). Subjects at the same concept share one system prompt, so each
level is asked breadth-first for all subjects at once.
"""
from __future__ import annotations

from dataclasses import dataclass

from ..ontology import Taxonomy
from ..oracle import Oracle
from ..prompts import level_question
from .asking import Progress, ask


@dataclass(frozen=True)
class Subject:
    """What is being classified: a key for the trace, a sentence framing it, the evidence shown."""

    key: str
    framing: str
    evidence: str


@dataclass(frozen=True)
class Typed:
    """A class reached by descent; confidence is the product of the shares along the path."""

    cls: str
    confidence: float


def descend(oracle: Oracle, tax: Taxonomy, start: str, subjects: list[Subject], stage: str,
            progress: Progress | None = None) -> list[Typed]:
    """Classify every subject below `start`, breadth-first."""
    typed = [Typed(start, 1.0)] * len(subjects)
    active = [i for i in range(len(subjects)) if tax.subclasses(start)]
    while active:
        questions = [
            level_question(tax, typed[i].cls, subjects[i].framing, subjects[i].evidence, subjects[i].key)
            for i in active
        ]
        verdicts = ask(oracle, questions, stage, progress)
        still = []
        for i, v in zip(active, verdicts):
            if v.answer is None or v.answer == typed[i].cls:
                continue  # abstention or the model stopped at the current concept: converged
            typed[i] = Typed(v.answer, typed[i].confidence * v.confidence)
            if tax.subclasses(v.answer):
                still.append(i)
        active = still
    return typed
