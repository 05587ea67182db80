"""A question in words, answered by one bundled query: the model chooses, code answers.

The options are computed from the knowledge base for the robot asked: every bundled query (by its file's
name, described by its title), each with the values its parameters can take on this robot: `side` one of
the sides its body parts have (or any), `part` one of its body-part classes (by their English labels),
`link` one of its links the question's own words name; other parameters keep their defaults. One
more option, `none`, stands for everything else. The embedded model scores every whole option in one
pass (pipeline.llm: Backend.score), as it scores the pipeline's questions; the menu of options is the
system text, the same for every question about the robot, so its prompt state is reused and a question
costs its own words and the options' tokens. The query whose options hold most of the probability is
chosen, with its likeliest values; `none`, or a query holding less than the threshold, is a refusal.

The reply's `answer` is one sentence composed by code from the query's rows (or, refused, one saying
what the robot can answer): no text is generated.
"""
from __future__ import annotations

import re
import threading
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import TypeVar

from rdflib import URIRef

from urdfkb import local_name
from urdfkb.kb_server.queries import NamedQuery, ParamError, load_queries, run_named
from urdfkb.kb_server.rows import table, units
from urdfkb.kb_server.sparql import Result
from urdfkb.kb_server.store import Store
from urdfkb.pipeline.llm.base import Backend, Question
from urdfkb.pipeline.oracle import softmax
from urdfkb.settings import ASK_THRESHOLD, MAX_QUESTION

T = TypeVar("T")
NONE = "none"
ANY = "any"
MAX_LINKS = 3  # link options offered for one question: those its words name best
MAX_LISTED = 6  # subjects a sentence names before "and N more"
_WORD = re.compile(r"[a-z0-9]+")
_FACTS = """PREFIX core: <https://w3id.org/urdfkb/core#>
PREFIX rdfs: <http://www.w3.org/2000/01/rdf-schema#>
SELECT DISTINCT ?kind ?value WHERE {
  { $robot core:hasLink/core:urdfName ?value BIND("link" AS ?kind) }
  UNION { $robot core:hasComponent+ ?p . ?p a ?c . ?c rdfs:subClassOf* core:BodyPart ; rdfs:label ?label
          FILTER(LANGMATCHES(LANG(?label), "en")) OPTIONAL { ?p core:side ?side }
          BIND("part" AS ?kind) BIND(CONCAT(STRAFTER(STR(?c), "#"), "|", STR(?label), "|", COALESCE(?side, "")) AS ?value) }
  UNION { $robot core:hasComponent ?x . ?x a ?c . ?c rdfs:subClassOf* core:Component ; rdfs:label ?label
          FILTER(LANGMATCHES(LANG(?label), "en")) FILTER NOT EXISTS { ?c rdfs:subClassOf* core:BodyPart }
          BIND("component" AS ?kind) BIND(STR(?label) AS ?value) }
}"""


class QuestionError(ParamError):
    """A question that cannot be asked: empty, or longer than MAX_QUESTION characters."""

    status = 400


@dataclass(frozen=True)
class Choice:
    option: str  # the text the model scores: the query's name, then its values
    query: str | None  # None: "none of these"
    params: tuple[tuple[str, str], ...] = ()


@dataclass(frozen=True)
class Menu:
    """What one robot can be asked: its choices (without links), its links, and the system text listing them."""

    robot: str
    system: str
    choices: tuple[Choice, ...]
    links: tuple[str, ...]
    link_queries: tuple[NamedQuery, ...]  # queries taking a `link`

    def question(self, text: str) -> tuple[Question, tuple[Choice, ...]]:
        """The question to score, with the choices its options stand for (link options: the links it names)."""
        words = set(_WORD.findall(text.lower()))
        named = sorted(((len(words & set(_WORD.findall(link.lower()))), -len(link), link) for link in self.links),
                       reverse=True)
        links = [link for hits, _, link in named[:MAX_LINKS] if hits]
        choices = self.choices + tuple(Choice(f"{q.name} {link}", q.name, (("link", link),))
                                       for q in self.link_queries for link in links)
        return Question(self.system, text.strip(), tuple(c.option for c in choices), key=f"ask:{self.robot}"), choices


def _facts(store: Store, robot: str) -> tuple[list[str], list[tuple[str, str, str]], list[str]]:
    """(links, body parts as (class, label, side), component class labels) of a stored robot."""
    entry = store.require(robot)
    result = store.query(_FACTS.replace("$robot", URIRef(entry.robot_iri).n3()))
    links, parts, components = [], [], []
    for row in result.as_dicts():
        if row["kind"] == "link":
            links.append(row["value"])
        elif row["kind"] == "part":
            cls, label, side = row["value"].split("|")
            parts.append((cls, label, side))
        else:
            components.append(row["value"])
    return sorted(links), sorted(set(parts)), sorted(set(components))


def build_menu(store: Store, robot: str) -> Menu:
    """The options robot `robot` offers, from what the knowledge base holds about it."""
    links, parts, components = _facts(store, robot)
    sides = sorted({side for _, _, side in parts if side})
    part_sides: dict[str, set[str]] = {}
    labels = {cls: label for cls, label, _ in parts}
    for cls, _, side in parts:
        part_sides.setdefault(cls, set()).update([side] if side else [])
    choices: list[Choice] = []
    lines = []
    link_queries = []
    for q in load_queries().values():
        names = {p.name for p in q.params}
        if "link" in names:
            link_queries.append(q)
            lines.append(f"{q.name} LINK: {q.title} (LINK: a link the question names)")
            continue
        if "part" in names:
            for cls in sorted(part_sides):
                part_values: list[str] = [ANY, *sorted(part_sides[cls])] if "side" in names and part_sides[cls] else [""]
                for value in part_values:
                    params = (("part", cls),) + ((("side", value),) if value else ())
                    choices.append(Choice(" ".join([q.name, labels[cls]] + ([value] if value else [])), q.name, params))
            lines.append(f"{q.name} PART{' SIDE' if 'side' in names else ''}: {q.title} "
                         f"(PART: {', '.join(labels[c] for c in sorted(part_sides))})")
        elif "side" in names and sides:
            choices += [Choice(f"{q.name} {side}", q.name, (("side", side),)) for side in [ANY, *sides]]
            lines.append(f"{q.name} SIDE: {q.title} (SIDE: {', '.join([*sides, ANY])})")
        else:
            choices.append(Choice(q.name, q.name))
            lines.append(f"{q.name}: {q.title}")
    choices.append(Choice(NONE, None))
    system = (f"A person talks to the robot {robot}. Choose the one query that answers what they ask about the "
              f"robot's own body, and its values; answer {NONE} when the question is about anything else "
              "(the weather, people, time, places, the battery, objects in the room, feelings, news...).\n"
              f"The robot's body parts: {', '.join(sorted(set(labels.values()))) or 'none known'}. "
              f"Its sides: {', '.join(sides) or 'none'}.\n"
              f"Its sensors and end-effectors: {', '.join(components) or 'none known'}.\n"
              "Queries:\n" + "\n".join(lines) + f"\n{NONE}: anything else\n"
              f"Answer with one query and its values, or {NONE}.")
    return Menu(robot, system, tuple(choices), tuple(links), tuple(link_queries))


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
        question, choices = menu.question(text)
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
