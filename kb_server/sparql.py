"""SPARQL 1.1 evaluation with Oxigraph (pyoxigraph), the checks run before it, and content negotiation.

The functions `run_query` and `run_update` evaluate one operation on a pyoxigraph Store; they run
inside the index's worker processes (kb_server/index.py). Results are serialised by Oxigraph's
own W3C writers (SPARQL results JSON/XML/CSV/TSV; Turtle, RDF/XML, N-Triples for graphs: the table of
pipeline/knowledge/formats.py), within the row and byte limits of kb_server/results.py.

Before anything is evaluated, `scan` reads the operation's tokens (strings, IRIs and comments
skipped) to refuse what would make the server fetch remote data (SERVICE, LOAD: pyoxigraph has an
HTTP client and would use it) or overflow the parser's stack (pyoxigraph 0.5 segfaults on ~50k
nested groups), and to find the dataset clauses (FROM / FROM NAMED must name local graphs).
"""
from __future__ import annotations

import io
import json
import re
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from functools import lru_cache
from urllib.parse import urljoin

import pyoxigraph as ox

from urdfkb.kb_server.results import ResultLimits, serialize
from urdfkb.pipeline.errors import UrdfkbError
from urdfkb.pipeline.knowledge.formats import GRAPH_MEDIA, RESULTS_MEDIA, RdfFormat, ResultsFormat
from urdfkb.settings import MAX_QUERY_NESTING

SCAN_CACHE, SCAN_CACHE_TEXT = 512, 64 * 1024  # query texts whose scan is kept, and the longest kept (characters)


class QueryError(UrdfkbError, ValueError):
    """The query (or update) is not valid SPARQL 1.1 or asks for something refused; the message says which."""

    status = 400


class QueryTimeout(UrdfkbError, RuntimeError):
    """The operation ran past its deadline and was stopped."""

    status = 503


class NotAcceptable(UrdfkbError, ValueError):
    """No offered media type matches the client's Accept header."""

    status = 406


@dataclass
class Result:
    """A serialised answer: kind "bindings", "boolean" or "graph", its media type and body."""

    kind: str
    media_type: str
    body: bytes
    _json: dict | None = field(default=None, repr=False)

    @property
    def document(self) -> dict:
        """The SPARQL results JSON document (only for results serialised as JSON)."""
        if self._json is None:
            self._json = json.loads(self.body)
        return self._json

    @property
    def vars(self) -> list[str]:
        return self.document["head"].get("vars", [])

    def bindings(self) -> list[dict[str, dict]]:
        """Rows as {var: JSON term}, unbound variables left out."""
        return self.document["results"]["bindings"]

    def as_dicts(self) -> list[dict[str, str]]:
        """Rows as {var: string value}, unbound variables left out (for JSON APIs and the CLI)."""
        return [{v: t["value"] for v, t in row.items()} for row in self.bindings()]


# --- lexical checks -----------------------------------------------------------------------
# The terminals of the SPARQL 1.1 grammar (its section 19.8) as Oxigraph's parser reads them: white space is
# exactly space, tab, CR and LF, a comment runs from # to the next CR or LF, a short string ends at neither.
# `scan` must see every token the engine sees, so that no keyword hides in what it took for a comment, a
# string or an IRI. Keywords are matched as the engine's PEG parser matches them, by prefix: it reads
# `SERVICESILENT<x>` as SERVICE SILENT <x> and `SERVICE:x` as SERVICE :x (measured on pyoxigraph 0.5).
_BASE = ("A-Za-z\u00c0-\u00d6\u00d8-\u00f6\u00f8-\u02ff\u0370-\u037d\u037f-\u1fff\u200c-\u200d"
         "\u2070-\u218f\u2c00-\u2fef\u3001-\ud7ff\uf900-\ufdcf\ufdf0-\ufffd\U00010000-\U000effff")
_CHARS_U = _BASE + "_"
_CHARS = _CHARS_U + "\\-0-9\u00b7\u0300-\u036f\u203f-\u2040"
_PLX = r"%[0-9A-Fa-f]{2}|\\[_~.\-!$&'()*+,;=/?#@%]"
_PREFIX = f"[{_BASE}](?:[{_CHARS}.]*[{_CHARS}])?"
_LOCAL = f"(?:[{_CHARS_U}:0-9]|{_PLX})(?:(?:[{_CHARS}.:]|{_PLX})*(?:[{_CHARS}:]|{_PLX}))?"
_LONG1 = r"'''(?:'{0,2}(?:[^'\\]|\\.))*'''"
_LONG2 = r'"""(?:"{0,2}(?:[^"\\]|\\.))*"""'
_SHORT1 = r"'(?:[^'\\\r\n]|\\.)*'"
_SHORT2 = r'"(?:[^"\\\r\n]|\\.)*"'
_TOKENS = re.compile("|".join(f"(?P<{kind}>{pattern})" for kind, pattern in [
    ("skip", r"[ \t\r\n]+|#[^\r\n]*"),
    ("string", "|".join((_LONG1, _LONG2, _SHORT1, _SHORT2))),
    ("iri", r'<[^<>"{}|^`\\\x00-\x20]*>'),
    ("var", f"[?$][{_CHARS_U}0-9][{_CHARS_U}0-9\u00b7\u0300-\u036f\u203f-\u2040]*"),
    ("pname", f"(?:{_PREFIX})?:(?:{_LOCAL})?|_:[{_CHARS_U}0-9](?:[{_CHARS}.]*[{_CHARS}])?"),
    ("word", "[A-Za-z]+"),
    ("open", r"[({\[]"),
    ("close", r"[)}\]]"),
    ("other", "."),
]), re.DOTALL)
_FETCHING = {"SERVICE": "SERVICE (federated query) is not supported: the server does not fetch remote data",
             "LOAD": "LOAD is not supported: the server does not fetch remote data"}


@dataclass(frozen=True)
class Scan:
    """What the lexical pass found: keywords at any depth, dataset IRIs (resolved) at depth 0."""

    keywords: frozenset[str]
    from_graphs: tuple[str | None, ...]  # None: a prefixed name with no PREFIX
    from_named: tuple[str | None, ...]


def tokens(text: str) -> Iterator[tuple[str, str]]:
    """(kind, text) of every significant token; the dataset keywords FROM and NAMED are split off what
    they are glued to (`FROMNAMED<x>`, `FROM:x`), as the engine splits them."""
    for m in _TOKENS.finditer(text):
        kind, tok = m.lastgroup or "", m.group()
        if kind == "skip":
            continue
        while kind in ("word", "pname") and tok[:4].upper() == "FROM" and len(tok) > 4:
            yield "word", "FROM"
            tok = tok[4:]
            if tok[:5].upper() == "NAMED" and len(tok) > 5:
                yield "word", "NAMED"
                tok = tok[5:]
            kind = "pname" if ":" in tok else "word"
        yield kind, tok


def scan(text: str, update: bool = False) -> Scan:
    """Read `text` as the engine does; QueryError for SERVICE (and LOAD in an update), however glued to
    what follows, or for nesting deeper than MAX_QUERY_NESTING. What a text up to SCAN_CACHE_TEXT
    characters gives is kept (the last SCAN_CACHE of them): clients ask the same queries again and again."""
    return _scan_kept(text, update) if len(text) <= SCAN_CACHE_TEXT else _scan(text, update)


def _scan(text: str, update: bool) -> Scan:
    keywords: set[str] = set()
    from_graphs: list[str | None] = []
    from_named: list[str | None] = []
    depth, base = 0, ""
    prefixes: dict[str, str] = {}
    refused = ("SERVICE", "LOAD") if update else ("SERVICE",)
    prev: list[tuple[str, str]] = []  # the last few significant tokens at depth 0
    for kind, tok in tokens(text):
        if kind == "open":
            depth += 1
            if depth > MAX_QUERY_NESTING:
                raise QueryError(f"query nests more than {MAX_QUERY_NESTING} levels of (), {{}} or []")
        elif kind == "close":
            depth = max(depth - 1, 0)
        elif kind in ("word", "pname"):
            upper = tok.upper()
            for keyword in refused:
                if upper.startswith(keyword):
                    raise QueryError(_FETCHING[keyword] + (f" (the engine reads {tok!r} as {keyword} ...)"
                                                           if upper != keyword else ""))
            if kind == "word":
                keywords.add(upper)
        if depth or kind == "open":
            continue
        prev = (prev + [(kind, tok)])[-3:]
        words = [t.upper() if k == "word" else t for k, t in prev]
        if kind in ("iri", "pname"):
            iri = _resolve(tok, base, prefixes)
            if len(words) >= 2 and words[-2] == "BASE":
                base = iri or base
            elif len(words) >= 3 and words[-3] == "PREFIX" and prev[-2][0] == "pname" and iri is not None:
                prefixes[prev[-2][1][:-1]] = iri
            elif len(words) >= 3 and words[-3:-1] == ["FROM", "NAMED"]:
                from_named.append(iri)
            elif len(words) >= 2 and words[-2] == "FROM":
                from_graphs.append(iri)
    return Scan(frozenset(keywords), tuple(from_graphs), tuple(from_named))


_scan_kept = lru_cache(maxsize=SCAN_CACHE)(_scan)  # a refusal (QueryError) is raised again each time, not kept


def _resolve(tok: str, base: str, prefixes: dict[str, str]) -> str | None:
    if tok.startswith("<"):
        return urljoin(base, tok[1:-1]) if base else tok[1:-1]
    prefix, _, local = tok.partition(":")
    return prefixes[prefix] + local if prefix in prefixes else None


def protocol_dataset(default: list[str], named: list[str]) -> tuple[list[str] | None, list[str] | None]:
    """The dataset a request's default-graph-uri and named-graph-uri values give (run_query's `default_graphs`,
    `named_graphs`): (None, None) when it gives none, so the union default graph stands."""
    return (default, named) if default or named else (None, None)


# --- evaluation (in a worker) -------------------------------------------------------------

def _graph(iri: str):
    return ox.NamedNode(iri)


def run_query(store: ox.Store, text: str, accept: str | None, default_graphs: list[str] | None = None,
              named_graphs: list[str] | None = None, limits: ResultLimits = ResultLimits()) -> Result:
    """Evaluate a query over `store` and serialise it for `accept`.

    The default graph is the union of all graphs unless the query's FROM / FROM NAMED or the
    protocol's default-graph-uri / named-graph-uri name a dataset (which must be local graphs).
    QueryError (400) on a malformed query, NotAcceptable (406) if no format fits `accept`,
    ResultTooLarge once the answer passes `limits`."""
    found = scan(text)
    kw: dict = {"use_default_graph_as_union": True}
    if default_graphs is not None or named_graphs is not None:
        kw = {"default_graph": [_graph(g) for g in default_graphs or []], "named_graphs": [_graph(g) for g in named_graphs or []]}
    if found.from_graphs or found.from_named:
        kw = {}  # the query names its own dataset
    for iri in [*(default_graphs or []), *(named_graphs or []), *found.from_graphs, *found.from_named]:
        if iri is None or not store.contains_named_graph(_graph(iri)):
            raise QueryError(f"the dataset names <{iri}>, which is no graph of this store "
                             "(the server never fetches remote data)")
    try:
        answer = store.query(text, **kw)
    except SyntaxError as e:
        raise QueryError(f"SPARQL syntax error: {e}") from None
    except (OSError, ValueError, TypeError) as e:
        raise QueryError(f"query failed: {e}") from None
    offers: Mapping[str, RdfFormat | ResultsFormat]
    if isinstance(answer, ox.QueryTriples):
        offers, kind = GRAPH_MEDIA, "graph"
    else:
        offers, kind = RESULTS_MEDIA, "boolean" if isinstance(answer, ox.QueryBoolean) else "bindings"
    media = negotiate(accept, list(offers))
    if media is None:
        raise NotAcceptable(f"no media type the Accept header allows is offered; offered: {', '.join(offers)}")
    try:
        return Result(kind, media, serialize(answer, offers[media].oxigraph, limits))
    except (OSError, ValueError) as e:  # evaluation errors surface while serialising lazily evaluated results
        raise QueryError(f"query failed: {e}") from None


def graph_dumps(store: ox.Store) -> dict[str, bytes]:
    """Every graph of `store` as N-Triples, keyed by graph IRI ("" for the default graph)."""
    out = {"": _ntriples(store, ox.DefaultGraph())}
    for g in store.named_graphs():
        out[g.value] = _ntriples(store, g)
    return out


def graph_dump(store: ox.Store, graph: str) -> bytes | None:
    """One named graph of `store` as N-Triples (None where the store has no such graph)."""
    node = _graph(graph)
    return _ntriples(store, node) if store.contains_named_graph(node) else None


def _ntriples(store: ox.Store, graph: ox.NamedNode | ox.BlankNode | ox.DefaultGraph) -> bytes:
    buf = io.BytesIO()  # written into rather than returned: dump's stub types its return as bytes | None
    store.dump(buf, format=ox.RdfFormat.N_TRIPLES, from_graph=graph)
    return buf.getvalue()


def run_update(store: ox.Store, text: str) -> dict[str, tuple[bytes | None, bytes | None]]:
    """Apply an update to `store`; returns {graph: (before, after)} for every graph it changed
    (N-Triples; None for a graph that did not / no longer exist(s))."""
    scan(text, update=True)
    before = graph_dumps(store)
    try:
        store.update(text)
    except SyntaxError as e:
        raise QueryError(f"SPARQL update syntax error: {e}") from None
    except (OSError, ValueError, TypeError) as e:
        raise QueryError(f"update failed: {e}") from None
    after = graph_dumps(store)
    return {g: (before.get(g), after.get(g)) for g in before.keys() | after.keys() if before.get(g) != after.get(g)}


def put_graph(store: ox.Store, graph: str, data: bytes | None) -> None:
    """Replace one graph of `store` ("" the default graph) with N-Triples `data`; None drops it."""
    target = ox.DefaultGraph() if graph == "" else _graph(graph)
    if graph == "":
        store.clear_graph(target)
    elif store.contains_named_graph(target):
        store.remove_graph(target)
    if data is not None:
        if graph:
            store.add_graph(target)
        store.load(data, format=ox.RdfFormat.N_TRIPLES, to_graph=target)


# --- content negotiation -------------------------------------------------------------------

def negotiate(accept: str | None, offers: list[str]) -> str | None:
    """The offer best matching an Accept header (q-values, then specificity, then the client's
    order); offers[0] when there is no header; None when nothing is acceptable."""
    if not accept or not accept.strip():
        return offers[0]
    best, best_key = None, None
    for pos, part in enumerate(accept.split(",")):
        fields = [f.strip() for f in part.split(";")]
        media, q = fields[0].lower(), 1.0
        for f in fields[1:]:
            if f.lower().startswith("q="):
                try:
                    q = float(f[2:])
                except ValueError:
                    q = 0.0
        if q <= 0 or not media:
            continue
        for rank, offer in enumerate(offers):
            if media == offer:
                spec = 2
            elif media == "*/*" or (media.endswith("/*") and offer.startswith(media[:-1])):
                spec = 0 if media == "*/*" else 1
            else:
                continue
            key = (q, spec, -pos, -rank)
            if best_key is None or key > best_key:
                best, best_key = offer, key
    return best
