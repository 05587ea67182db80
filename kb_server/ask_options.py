"""What a question in words can be answered with: the options the knowledge base offers for one robot.

Every bundled query is an option, with the values its parameters can take on that robot; code fixes
the values the question's own words name, and the model chooses among the rest:
- `link`: the robot's links the question names (their name's words in a row: "head_pan_link", "head
  pan link"); a query taking a link is no option where it names none;
- `side`: the robot's side a word outside those links names ("left", "rigth"), else any (also where it
  names both);
- `part`: the body-part classes whose English label a word outside those links names (its head noun:
  "base" for "mobile base", plural or misspelt alike); the model chooses among those named, or among all
  of the robot's classes where it names none; `side` as above where the robot has that class on that side.
Other parameters keep their defaults. One more option, `none`, stands for everything else. The model
reads the question followed by what of the robot's body code found it names (Menu.user).
"""
from __future__ import annotations

import re
from dataclasses import dataclass

from rapidfuzz.distance import OSA
from rdflib import URIRef

from urdfkb.kb_server.queries import NamedQuery, load_queries
from urdfkb.kb_server.store import Store

NONE = "none"
ANY = "any"
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


@dataclass(frozen=True)
class Choice:
    option: str  # the text the model scores: the query's name, then the values it chooses among
    query: str | None  # None: "none of these"
    params: tuple[tuple[str, str], ...] = ()


@dataclass(frozen=True)
class Part:
    """A body-part class the robot has: its class name, English label and the sides it has it on."""

    cls: str
    label: str
    sides: tuple[str, ...]


def words(text: str) -> list[str]:
    return _WORD.findall(text.lower())


def names(word: str, said: list[str]) -> bool:
    """Whether the question's words `said` name `word`: as written, in the plural, or misspelt by one edit
    (a letter added, dropped, changed, or two neighbours swapped: "rigth", "lefft") where one of the two has
    five letters or more and neither fewer than four ("where" is no "wheel", "hear" no "head")."""
    for w in said:
        if w in (word, word + "s", word + "es"):
            return True
        if min(len(w), len(word)) >= 4 and max(len(w), len(word)) >= 5 and OSA.distance(w, word) <= 1:
            return True
    return False


@dataclass(frozen=True)
class Named:
    """What a question names of the robot's body: one side (else ANY), body-part classes and links (the longest first)."""

    side: str
    parts: tuple[Part, ...]
    links: tuple[str, ...]


@dataclass(frozen=True)
class Menu:
    """What one robot can be asked: its queries, body parts, sides and links, and the system text listing them."""

    robot: str
    system: str
    queries: tuple[NamedQuery, ...]
    parts: tuple[Part, ...]
    sides: tuple[str, ...]
    links: tuple[str, ...]

    def read(self, text: str) -> Named:
        """What of the robot's body question `text` names: its links, then, in the words outside them, a side and
        body parts."""
        said = f" {' '.join(words(text))} "
        links = sorted((link for link in self.links if f" {' '.join(words(link))} " in said), key=lambda k: (-len(k), k))
        for link in links:
            said = said.replace(f" {' '.join(words(link))} ", " ")
        rest = said.split()
        sides = [s for s in self.sides if names(s, rest)]
        return Named(sides[0] if len(sides) == 1 else ANY,
                     tuple(p for p in self.parts if names(p.label.split()[-1], rest)), tuple(links))

    def user(self, text: str) -> str:
        """The user turn the model reads: the question, then what of the robot's body code found it names."""
        named = self.read(text)
        parts = [f"{named.side} {p.label}" if named.side in p.sides else p.label for p in named.parts]
        found = ([f"body part {', '.join(parts)}"] if parts else []) + ([f"link {', '.join(named.links)}"] if named.links else [])
        return text.strip() + (f"\n(It names the robot's {' and '.join(found)}.)" if found else "")

    def choices(self, text: str) -> tuple[Choice, ...]:
        """The options for question `text`: per query, the values code does not fix by the question's words
        (every body part of the robot where the question names none)."""
        named = self.read(text)
        side, parts, links = named.side, named.parts or self.parts, named.links
        out: list[Choice] = []
        for q in self.queries:
            params = {p.name for p in q.params}
            if "link" in params:
                out += [Choice(f"{q.name} {link}" if len(links) > 1 else q.name, q.name, (("link", link),))
                        for link in links]
            elif "part" in params:
                for part in parts:
                    values: tuple[tuple[str, str], ...] = (("part", part.cls),)
                    if "side" in params and part.sides:
                        values += (("side", side if side in part.sides else ANY),)
                    out.append(Choice(f"{q.name} {part.label}" if len(parts) > 1 else q.name, q.name, values))
            elif "side" in params and self.sides:
                out.append(Choice(q.name, q.name, (("side", side),)))
            else:
                out.append(Choice(q.name, q.name))
        return (*out, Choice(NONE, None))


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
    links, rows, components = _facts(store, robot)
    labels = {cls: label for cls, label, _ in rows}
    parts = tuple(Part(cls, labels[cls], tuple(sorted({side for c, _, side in rows if c == cls and side})))
                  for cls in sorted(labels))
    sides = tuple(sorted({side for part in parts for side in part.sides}))
    queries = tuple(load_queries().values())
    lines = [f"{q.name}: {q.title}" + (f"; asked as: {q.in_words}" if q.in_words else "") for q in queries]
    system = (f"A person talks to the robot {robot}. Choose the one query that answers what they ask about the "
              "robot's own body: its parts, links, joints, sensors and devices. Answer "
              f"{NONE} when the question is about anything else (the weather, people, time, places, the battery, "
              "things around the robot, feelings, news...). A question naming one of the robot's body parts or links is "
              "about its body.\n"
              f"The robot's body parts: {', '.join(p.label for p in parts) or 'none known'}. "
              f"Its sides: {', '.join(sides) or 'none'}.\n"
              f"Its sensors and end-effectors: {', '.join(components) or 'none known'}.\n"
              "Queries:\n" + "\n".join(lines) + f"\n{NONE}: anything else\n"
              f"Answer with the query's name, or {NONE}.")
    return Menu(robot, system, queries, parts, sides, tuple(links))
