"""Declared passes and the manager that runs them, in the style of numba's PassManager.

A pass is a name and a list of named steps; a step is a function of the pass's context (what lasts
across passes) and its state (what this pass has built so far). The manager runs a pass's steps in
order, ends the pass early when a step sets `state.done` (nothing left to abstract), and writes each
step's wall time to the trace as `{"key": "timing", "pass": ..., "step": ..., "seconds": ...}`, with
what the `counters` counted during the step (model seconds, tokens, ...: pipeline.timings).
Timings go to the trace only, never into a prompt or the ontology. pipeline.abstraction declares the
passes; adding one is adding a list of steps there.

Each step declares the analyses it reads (`needs`) and those it makes (`makes`), by name: the finger
structure, the identification claims, the groups... `check_order` (numba's `finalize`) verifies, once,
when the passes are declared, that every analysis a step needs was given at the start or made by an
earlier step of this pass or an earlier pass, so a step moved before what it reads fails at import,
not with a wrong answer.
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any, Callable, Protocol


class State(Protocol):
    done: bool


@dataclass(frozen=True)
class Step:
    name: str
    run: Callable[[Any, Any], None]  # (context, state) -> None
    needs: tuple[str, ...] = ()  # analyses it reads
    makes: tuple[str, ...] = ()  # analyses it makes (or remakes)


@dataclass(frozen=True)
class Pass:
    name: str
    steps: tuple[Step, ...]

    def __post_init__(self) -> None:
        names = [s.name for s in self.steps]
        if len(set(names)) != len(names):
            raise ValueError(f"pass {self.name!r} names a step twice: {names}")


def check_order(passes: tuple[Pass, ...], given: tuple[str, ...]) -> None:
    """ValueError naming the first step that needs an analysis neither `given` nor an earlier step makes."""
    made = set(given)
    for declared in passes:
        for step in declared.steps:
            if missing := [n for n in step.needs if n not in made]:
                raise ValueError(f"pass {declared.name!r}, step {step.name!r} needs {', '.join(missing)}, "
                                 "which no earlier step makes")
            made.update(step.makes)


class PassManager:
    """Runs passes step by step; `record` receives each step's timing (the trace writer), with the
    change of each of `counters`' running totals over the step."""

    def __init__(self, record: Callable[[dict], None], counters: Callable[[], dict[str, float]] | None = None):
        self.record = record
        self.counters = counters or dict

    def run(self, declared: Pass, context: Any, state: State) -> None:
        for step in declared.steps:
            before, started = self.counters(), time.perf_counter()
            step.run(context, state)
            seconds, after = time.perf_counter() - started, self.counters()
            self.record({"key": "timing", "pass": declared.name, "step": step.name, "seconds": round(seconds, 4),
                         **{name: round(after[name] - value, 4) for name, value in before.items()}})
            if state.done:
                return
