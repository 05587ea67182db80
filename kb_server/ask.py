"""A question in words, answered by one bundled query: the model chooses, code answers.

The options (kb_server.ask_options) are the bundled queries with the values the question leaves open on
the robot asked, and `none` for everything else. The embedded model scores every whole option in one pass
(pipeline.llm: Backend.score), as it scores the pipeline's questions; the menu of queries is the system
text, the same for every question about the robot, so its prompt state is reused and a question costs its
own words, a line saying what of the robot's body it names (Menu.user) and the options' tokens. The query whose options hold most of the probability is chosen, with
its likeliest values; `none`, or a query holding less than the threshold, is a refusal.

The reply's `answer` is one sentence composed by code from the query's rows (or, refused, one saying
what the robot can answer): no text is generated.
"""
from __future__ import annotations

import re
import threading
from collections.abc import Callable, Mapping
from typing import TypeVar

from urdfkb import local_name
from urdfkb.kb_server.ask_options import Menu, build_menu
from urdfkb.kb_server.queries import NamedQuery, ParamError, load_queries, run_named
from urdfkb.kb_server.rows import table, units
from urdfkb.kb_server.sparql import Result
from urdfkb.kb_server.store import Store
from urdfkb.pipeline.llm.base import Backend, Question
from urdfkb.pipeline.abstraction.oracle import softmax
from urdfkb.settings import ASK_THRESHOLD, MAX_QUESTION

T = TypeVar("T")
MAX_LISTED = 6  # subjects a sentence names before "and N more"


class QuestionError(ParamError):
    """A question that cannot be asked: empty, or longer than MAX_QUESTION characters."""

    status = 400


def sentence(query: NamedQuery, result: Result, unit_of: Mapping[str, str] | None = None) -> str:
    """One sentence saying what the rows hold: the query's title, then each subject (the first column's
    value, or its `name`) with the other values of its rows."""
    rows = result.as_dicts()
    if not rows:
        return f"{query.title}: none."
    first = result.vars[0]
    subjects: dict[str, list[str]] = {}
    for row in rows:
        subject = _shown(row.get("name") or row.get(first, "?"))
        details = subjects.setdefault(subject, [])
        for var in result.vars:
            if var in (first, "name") or var not in row:
                continue
            value = _shown(row[var]) + (f" {unit_of[var]}" if unit_of and var in unit_of else "")
            if (item := f"{_words(var)} {value}") not in details:
                details.append(item)
    listed = [f"{s} ({', '.join(d)})" if d else s for s, d in list(subjects.items())[:MAX_LISTED]]
    more = len(subjects) - MAX_LISTED
    return f"{query.title}: {'; '.join(listed)}{f'; and {more} more' if more > 0 else ''}."


def _shown(value: str) -> str:
    return local_name(value) if value.startswith("http") else value


def _words(var: str) -> str:
    """A column's name in words: degreesOfFreedom -> degrees of freedom."""
    return re.sub(r"(?<=[a-z])(?=[A-Z])", " ", var).lower()


def refusal(robot: str) -> str:
    titles = [q.title[0].lower() + q.title[1:] for q in load_queries().values()]
    return (f"That question is outside what I, {robot}, know about my body. I can answer: "
            + "; ".join(titles) + ".")


class Asker:
    """Answers questions in words with a backend reached through `use` (use(task) runs task(backend), on the
    thread the backend belongs to); menus are kept per robot and write time."""

    def __init__(self, use: Callable[[Callable[[Backend], list[list[float]]]], list[list[float]]],
                 threshold: float = ASK_THRESHOLD):
        self.use = use
        self.threshold = threshold
        self._menus: dict[tuple[str, str], Menu] = {}
        self._lock = threading.Lock()

    def menu(self, store: Store, robot: str) -> Menu:
        key = (robot, store.require(robot).updated)
        with self._lock:
            menu = self._menus.get(key)
        if menu is None:
            menu = build_menu(store, robot)
            with self._lock:
                self._menus = {k: v for k, v in self._menus.items() if k[0] != robot} | {key: menu}
        return menu

    def ask(self, store: Store, robot: str, text: str) -> dict:
        """The reply to `text` about stored robot `robot`: query, params, rows, answer, confidence, refused."""
        if not text.strip():
            raise QuestionError("the question is empty: ask something about the robot's body")
        if len(text) > MAX_QUESTION:
            raise QuestionError(f"the question is longer than {MAX_QUESTION} characters")
        menu = self.menu(store, robot)
        choices = menu.choices(text)
        question = Question(menu.system, menu.user(text), tuple(c.option for c in choices), key=f"ask:{robot}",
                            until_unique=True)
        (scores,) = self.use(lambda backend: backend.score([question]))
        probabilities = softmax(scores)
        mass: dict[str | None, float] = {}
        for choice, p in zip(choices, probabilities):
            mass[choice.query] = mass.get(choice.query, 0.0) + p
        query = max(mass, key=lambda q: mass[q])
        confidence = round(mass[query], 4)
        if query is None or mass[query] < self.threshold:
            return {"robot": robot, "question": text, "query": None, "params": {}, "rows": [],
                    "answer": refusal(robot), "confidence": confidence, "refused": True}
        best = max((c for c in zip(choices, probabilities) if c[0].query == query), key=lambda c: c[1])[0]
        named = load_queries()[query]
        result = run_named(store, query, robot, dict(best.params))
        answer = table(result, units(named.text))
        return {"robot": robot, "question": text, "query": query, "params": dict(best.params),
                "rows": answer["rows"], "units": answer["units"],
                "answer": sentence(named, result, answer["units"]), "confidence": confidence, "refused": False}


def direct(backend: Backend) -> Callable[[Callable[[Backend], T]], T]:
    """`use` for a backend this thread owns (the command line, tests)."""
    return lambda task: task(backend)
