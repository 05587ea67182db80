"""Named HRI queries (queries/*.rq) with safely bound parameters.

A query file is SPARQL whose header comments give a title and its parameters:

    # title: What is mounted on or below a link
    # param link: string - URDF name of the link
    # param side: string = any - what it means
    # param threshold: decimal = {REVIEW_THRESHOLD} - what it means
    # in words: what is mounted under a link, what hangs below it

`# in words` says, in the words a person would use, what questions the query answers (the options of a
question in words: kb_server.ask_options). A parameter's default follows `=`; written `{NAME}`, it is the setting NAME of urdfkb.settings, filled in as the file
is loaded, so a default the server also uses elsewhere (the review threshold of the pages) has one home
and the file stays a SPARQL query Protégé or any client can read.

`$robot` is always bound to the robot's individual IRI; other `$name` variables to the request's
values, validated for their type and written into the text as escaped RDF terms (`Literal(...).n3()`)
in one pass over the file's text, so a value is one term, never query syntax. Oxigraph does not bind
them itself: pyoxigraph 0.5's `Store.query(substitutions=...)` refuses a variable the SELECT does
not project ("does not contains variable ?threshold in its SELECT projection"), and projecting
`?robot` and `?threshold` would add columns to every answer.
"""
from __future__ import annotations

import importlib.resources
import re
from collections.abc import Mapping
from dataclasses import dataclass
from decimal import Decimal, InvalidOperation
from functools import cache
from pathlib import Path

from rdflib import Literal, URIRef
from rdflib.namespace import XSD

from urdfkb import local_name, settings
from urdfkb.kb_server.sparql import Result
from urdfkb.kb_server.store import Store
from urdfkb.pipeline.errors import UrdfkbError
from urdfkb.pipeline.knowledge.formats import RESULTS_BY_NAME
from urdfkb.settings import QUERY_TIMEOUT

_PARAM = re.compile(r"^#\s*param\s+(\w+)\s*:\s*(\w+)(?:\s*=\s*(\S+))?(?:\s*-\s*(.*))?$")
_SETTING = re.compile(r"^\{([A-Z][A-Z0-9_]*)\}$")
_VAR = re.compile(r"\$(\w+)")
TYPES = ("string", "decimal", "integer")
MAX_STRING = 1000  # characters of a string parameter
MAX_NUMBER = 100  # characters of a numeric parameter as written
MAX_DIGITS = 40  # digits of a numeric parameter written out, either side of the decimal point


class ParamError(UrdfkbError, ValueError):
    """A missing, unknown or ill-typed query parameter."""

    status = 400


class UnknownQuery(UrdfkbError, LookupError):
    """No query of that name."""

    status = 404


@dataclass(frozen=True)
class Param:
    name: str
    type: str
    default: str | None
    doc: str

    def term(self, raw: str) -> Literal:
        """The value as a typed RDF term; ParamError if it does not fit the type or its bounds: a string of at
        most MAX_STRING characters, a number of at most MAX_NUMBER characters whose plain decimal form has
        at most MAX_DIGITS digits either side of the point (`1e999999999` would be a billion digits)."""
        if self.type == "string":
            if len(raw) > MAX_STRING:
                raise ParamError(f"parameter {self.name!r} is longer than {MAX_STRING} characters")
            return Literal(raw)
        kind = "a decimal" if self.type == "decimal" else "an integer"
        if len(raw) > MAX_NUMBER:
            raise ParamError(f"parameter {self.name!r} must be {kind} of at most {MAX_NUMBER} characters, "
                             f"got {len(raw)} characters")
        try:
            number = Decimal(raw) if self.type == "decimal" else Decimal(int(raw))
        except (InvalidOperation, ValueError):
            raise ParamError(f"parameter {self.name!r} must be {kind}, got {raw!r}") from None
        if not number.is_finite():
            raise ParamError(f"parameter {self.name!r} must be finite, got {raw!r}")
        exponent = number.as_tuple().exponent
        assert isinstance(exponent, int)  # finite
        if not (-MAX_DIGITS <= exponent and number.adjusted() < MAX_DIGITS):
            raise ParamError(f"parameter {self.name!r} must be written with at most {MAX_DIGITS} digits before "
                             f"and {MAX_DIGITS} after the decimal point, got {raw!r}")
        return Literal(format(number, "f"), datatype=XSD.decimal if self.type == "decimal" else XSD.integer)


@dataclass(frozen=True)
class NamedQuery:
    name: str
    title: str
    text: str
    params: tuple[Param, ...]
    in_words: str = ""

    def describe(self) -> dict:
        return {"name": self.name, "title": self.title,
                "params": [{"name": p.name, "type": p.type, "default": p.default, "doc": p.doc} for p in self.params]}

    def bind(self, robot_iri: str, args: Mapping[str, str]) -> str:
        """The query text with $robot and every parameter replaced by its RDF term."""
        known = {p.name for p in self.params}
        unknown = sorted(set(args) - known)
        if unknown:
            raise ParamError(f"query {self.name!r} has no parameter {', '.join(unknown)} (it takes: {', '.join(sorted(known)) or 'none'})")
        terms: dict[str, URIRef | Literal] = {"robot": URIRef(robot_iri)}
        for p in self.params:
            raw = args.get(p.name, p.default)
            if raw is None:
                raise ParamError(f"query {self.name!r} needs parameter {p.name!r} ({p.doc or p.type})")
            terms[p.name] = p.term(raw)
        return _VAR.sub(lambda m: terms[m.group(1)].n3(), self.text)


def _parse(name: str, text: str) -> NamedQuery:
    title, in_words, params = name, "", []
    for line in text.splitlines():
        if line.startswith("# title:"):
            title = line.split(":", 1)[1].strip()
        elif line.startswith("# in words:"):
            in_words = line.split(":", 1)[1].strip()
        elif m := _PARAM.match(line):
            pname, ptype, default, doc = m.groups()
            if ptype not in TYPES or pname == "robot":
                raise ValueError(f"query file {name}.rq: bad parameter declaration {line!r}")
            params.append(Param(pname, ptype, _setting(name, default), (doc or "").strip()))
    declared = {p.name for p in params} | {"robot"}
    used = set(_VAR.findall(text))
    if used != declared:
        raise ValueError(f"query file {name}.rq: variables {sorted(used)} do not match parameters {sorted(declared)}")
    return NamedQuery(name, title, text, tuple(params), in_words)


def _setting(name: str, default: str | None) -> str | None:
    """A parameter's default, with a `{NAME}` placeholder replaced by urdfkb.settings.NAME."""
    if default is None or (m := _SETTING.match(default)) is None:
        return default
    if not hasattr(settings, m.group(1)):
        raise ValueError(f"query file {name}.rq: no setting {m.group(1)} in urdfkb.settings")
    return str(getattr(settings, m.group(1)))


@cache
def load_queries() -> dict[str, NamedQuery]:
    """All packaged queries by name (file stem)."""
    root = importlib.resources.files("urdfkb.queries")
    return {f.name[:-3]: _parse(f.name[:-3], f.read_text(encoding="utf-8"))
            for f in sorted(root.iterdir(), key=lambda f: f.name) if f.name.endswith(".rq")}


def run_named(store: Store, name: str, robot: str, args: Mapping[str, str], timeout: float = QUERY_TIMEOUT,
              accept: str | None = None) -> Result:
    """Run query `name` for stored robot `robot`; UnknownQuery, UnknownRobot or ParamError on bad input."""
    query = load_queries().get(name)
    if query is None:
        raise UnknownQuery(f"no query {name!r} (known: {', '.join(load_queries())})")
    return store.query(query.bind(store.require(robot).robot_iri, args), timeout, accept)


def components(store: Store, robot: str) -> list[dict]:
    """The robot's components with class, confidence, mount and sub-components, as JSON-ready dicts."""
    result = run_named(store, "components", robot, {})
    out: dict[str, dict] = {}
    for row in result.as_dicts():
        comp = out.setdefault(row["component"], {
            "iri": row["component"], "class": local_name(row["class"]),
            "confidence": float(row["confidence"]) if "confidence" in row else None,
            "mount": row.get("mount"), "subcomponents": []})
        if "sub" in row:
            comp["subcomponents"].append({
                "iri": row["sub"], "class": local_name(row["subClass"]), "link": row.get("subLink"),
                "confidence": float(row["subConfidence"]) if "subConfidence" in row else None})
    return list(out.values())


def run_named_query(name: str, robot: str, params: Mapping[str, str], store_path: str | Path | None = None, fmt: str = "table",
                    timeout: float = QUERY_TIMEOUT) -> str:
    """`urdfkb query NAME --robot NAME [--param k=v]`: a named query on a store file, as text.

    fmt: "table" (aligned columns, IRIs shortened to their local name) or a SPARQL results format's
    name ("json", "xml", "csv", "tsv": pipeline.knowledge.formats). Raises UnknownQuery, UnknownRobot, ParamError, QueryError or
    QueryTimeout (all UrdfkbError) with a clear message.
    """
    if fmt != "table" and fmt not in RESULTS_BY_NAME:
        raise ParamError(f"unknown format {fmt!r}; choose one of table, {', '.join(RESULTS_BY_NAME)}")
    store = Store(store_path, workers=1)  # one worker process: the timeout is enforced
    try:
        result = run_named(store, name, robot, params, timeout, RESULTS_BY_NAME["json" if fmt == "table" else fmt].media_type)
    finally:
        store.close()
    return _table(result) if fmt == "table" else result.body.decode("utf-8")


def _table(result: Result) -> str:
    rows = result.as_dicts()
    cells = [[local_name(row[v]) if "#" in row.get(v, "") else row.get(v, "") for v in result.vars] for row in rows]
    widths = [max([len(v)] + [len(r[i]) for r in cells]) for i, v in enumerate(result.vars)]
    lines = ["  ".join(v.ljust(w) for v, w in zip(result.vars, widths)).rstrip(),
             "  ".join("-" * w for w in widths)]
    lines += ["  ".join(c.ljust(w) for c, w in zip(r, widths)).rstrip() for r in cells]
    lines.append(f"({len(cells)} row{'s' if len(cells) != 1 else ''})")
    return "\n".join(lines)
