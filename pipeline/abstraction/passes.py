"""Declared passes and the manager that runs them, in the style of numba's PassManager.

A pass is a name and a list of steps; a step is a plain function of the pass's context
(pipeline.abstraction.steps.context) and the findings record (pipeline.abstraction.steps.findings), declared with `@step`
and the record's fields it reads (`needs`) and makes or updates (`makes`), as spaCy components
declare `requires` and `assigns`. The names are checked when a step is declared: a name that is not a
field of the record raises there, at import. `check_order` (numba's `finalize`) then verifies, once,
when the passes are declared, that every field a step needs was given at the start or made by an
earlier step: of this pass, or of an earlier pass for a field that lasts from pass to pass. So a step
moved before what it reads fails at import, not with a wrong answer; tests/test_step_declarations.py
checks on generated robots that the steps read and write only what they declare.

The manager runs a pass's steps in order, ends the pass early when a step sets `done` (nothing left
to abstract), adds the pass and step to the notes of an error raised inside a step, and writes each
step's wall time to the trace as `{"key": "timing", "pass": ..., "step": ..., "seconds": ...}`, with
what the `counters` counted during the step (model seconds, tokens, ...: pipeline.timings). Timings
go to the trace only, never into a prompt or the ontology.
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any, Callable, Protocol

from urdfkb.pipeline.abstraction.steps.findings import FIELDS


class State(Protocol):
    done: bool


@dataclass(frozen=True)
class Step:
    name: str
    run: Callable[[Any, Any], None]  # (context, findings) -> None
    needs: tuple[str, ...] = ()  # fields it reads
    makes: tuple[str, ...] = ()  # fields it makes or updates (an update reads the field too)

    def __call__(self, context: Any, findings: Any) -> None:
        self.run(context, findings)


def step(name: str, needs: tuple[str, ...] = (), makes: tuple[str, ...] = ()) -> Callable[[Callable[[Any, Any], None]], Step]:
    """Declare a step function named `name`; ValueError when a name in `needs` or `makes` is not a field of
    the findings record."""
    if unknown := [n for n in (*needs, *makes) if n not in FIELDS]:
        raise ValueError(f"step {name!r} declares {', '.join(unknown)}: no such field of the findings record "
                         "(pipeline.abstraction.steps.findings)")

    def declare(run: Callable[[Any, Any], None]) -> Step:
        return Step(name, run, needs, makes)
    return declare


@dataclass(frozen=True)
class Pass:
    name: str
    steps: tuple[Step, ...]

    def __post_init__(self) -> None:
        names = [s.name for s in self.steps]
        if len(set(names)) != len(names):
            raise ValueError(f"pass {self.name!r} names a step twice: {names}")


def check_order(passes: tuple[Pass, ...], given: tuple[str, ...], lasting: frozenset[str] = frozenset()) -> None:
    """ValueError naming the first step that needs a field neither `given` nor an earlier step makes; a field
    made in an earlier pass counts only if it is `lasting`."""
    kept = set(given)
    for declared in passes:
        made = set(kept)
        for s in declared.steps:
            if missing := [n for n in s.needs if n not in made]:
                raise ValueError(f"pass {declared.name!r}, step {s.name!r} needs {', '.join(missing)}, "
                                 "which no earlier step makes")
            made.update(s.makes)
        kept |= made & lasting


class PassManager:
    """Runs passes step by step; `record` receives each step's timing (the trace writer), with the
    change of each of `counters`' running totals over the step."""

    def __init__(self, record: Callable[[dict], None], counters: Callable[[], dict[str, float]] | None = None):
        self.record = record
        self.counters = counters or dict

    def run(self, declared: Pass, context: Any, findings: State) -> None:
        for s in declared.steps:
            before, started = self.counters(), time.perf_counter()
            try:
                s.run(context, findings)
            except Exception as error:
                error.add_note(f"in pass {declared.name!r}, step {s.name!r}")
                raise
            seconds, after = time.perf_counter() - started, self.counters()
            self.record({"key": "timing", "pass": declared.name, "step": s.name, "seconds": round(seconds, 4),
                         **{name: round(after[name] - value, 4) for name, value in before.items()}})
            if findings.done:
                return
