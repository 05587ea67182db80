"""Stages 3 and 6, pre- and post-classification, and stage 7's sub-part typing: descents of the taxonomy.

Each subject starts at a concept and goes down one level per question, choosing among the direct
subclasses the ontology offers (minus those the schema rules out for the subject), until it
reaches a leaf concept or the model abstains. A concept the ontology lets a device stay at (core:otherAnswer:
a ranging sensor that is neither lidar nor sonar) offers that answer beside its subclasses. A concept with a
lone allowed subclass and no such answer is no choice and is passed through without a question. Subjects at the same concept share one system prompt,
so each level is asked breadth-first for all subjects at once.
"""
from __future__ import annotations

from dataclasses import dataclass

from urdfkb.pipeline.knowledge.ontology import Vocabulary
from urdfkb.pipeline.abstraction.oracle import Oracle
from urdfkb.pipeline.abstraction.prompts import level_choice, level_options
from urdfkb.pipeline.abstraction.stages.asking import Progress, ask


@dataclass(frozen=True)
class Subject:
    """What is being classified: a key for the trace, a sentence framing it ({concept} is filled in), the evidence."""

    key: str
    framing: str
    evidence: str
    exclude: frozenset[str] = frozenset()  # classes the schema rules out for this subject
    stay: tuple[str, str] | None = None  # (answer, definition): an option to stay at the start class, offered there


@dataclass(frozen=True)
class Typed:
    """A class reached by descent; confidence is the product of the shares along the path."""

    cls: str
    confidence: float


def descend(oracle: Oracle, tax: Vocabulary, start: str, subjects: list[Subject], stage: str,
            progress: Progress | None = None) -> list[Typed]:
    """Classify every subject below `start`, breadth-first."""
    typed = [_through_lone(tax, Typed(start, 1.0), s.exclude) for s in subjects]
    active = [i for i in range(len(subjects)) if level_options(tax, typed[i].cls, subjects[i].exclude)]
    while active:
        choices = [
            level_choice(tax, typed[i].cls, subjects[i].framing, subjects[i].evidence, subjects[i].key, subjects[i].exclude,
                         subjects[i].stay if typed[i].cls == start and subjects[i].stay else tax.other(typed[i].cls))
            for i in active
        ]
        verdicts = ask(oracle, [c.question for c in choices], stage, progress)
        still = []
        for i, c, v in zip(active, choices, verdicts):
            cls = c.meant(v.answer, None)
            if cls is None:
                continue  # abstention: converged
            if cls == typed[i].cls:  # the model chose to stay at the current concept: its share counts
                typed[i] = Typed(cls, typed[i].confidence * v.confidence)
                continue
            typed[i] = _through_lone(tax, Typed(cls, typed[i].confidence * v.confidence), subjects[i].exclude)
            if level_options(tax, typed[i].cls, subjects[i].exclude):
                still.append(i)
        active = still
    return typed


def _through_lone(tax: Vocabulary, typed: Typed, exclude: frozenset[str]) -> Typed:
    """Follow lone allowed subclasses down (VisionSensor → Camera): there is nothing to ask."""
    while len(subs := level_options(tax, typed.cls, exclude)) == 1 and tax.other(typed.cls) is None:
        typed = Typed(subs[0], typed.confidence)
    return typed
