"""SPARQL 1.1 evaluation over an owlready2 world, and the W3C result formats.

Every query is parsed by rdflib first (strict SPARQL 1.1 grammar, its message on error, parses
cached). SELECT queries owlready2's native engine can translate run natively (fast, SQL); the
rest (ASK, CONSTRUCT, DESCRIBE, MINUS, NOT EXISTS, inverse paths, ...) run through rdflib over
the same quadstore. Results are serialised here, never by owlready2.
"""
from __future__ import annotations

import csv
import io
import json
import math
import sqlite3
import time
from contextlib import contextmanager
from dataclasses import dataclass, field
from functools import lru_cache
from xml.etree import ElementTree as ET

import rdflib
from owlready2.rdflib_store import TripleLiteRDFlibGraph
from owlready2.sparql.main import PreparedSelectQuery
from pyparsing import ParseException
from rdflib import BNode, Literal, URIRef
from rdflib.plugins.sparql import prepareQuery
from rdflib.plugins.sparql.algebra import translateUpdate
from rdflib.plugins.sparql.parser import parseUpdate
from rdflib.plugins.sparql.parserutils import CompValue

from pipeline.errors import UrdfkbError

XSD = "http://www.w3.org/2001/XMLSchema#"
UPDATES_IRI = "https://w3id.org/urdfkb/updates#"
XSD_STRING = URIRef(XSD + "string")
SRX_NS = "http://www.w3.org/2005/sparql-results#"

SELECT_TYPES = {
    "application/sparql-results+json": "json",
    "application/json": "json",
    "application/sparql-results+xml": "xml",
    "application/xml": "xml",
    "text/csv": "csv",
    "text/tab-separated-values": "tsv",
}
GRAPH_TYPES = {
    "text/turtle": "turtle",
    "application/rdf+xml": "xml",
    "application/n-triples": "nt",
    "text/plain": "nt",
}


class QueryError(UrdfkbError, ValueError):
    """The query (or update) is not valid SPARQL 1.1; the message is the parser's."""


class QueryTimeout(UrdfkbError, RuntimeError):
    """The query ran past its deadline and was stopped."""


@dataclass
class Result:
    """A query answer: variable bindings (SELECT), a boolean (ASK) or a graph (CONSTRUCT/DESCRIBE)."""

    kind: str  # "bindings" | "boolean" | "graph"
    vars: list[str] = field(default_factory=list)
    rows: list[tuple] = field(default_factory=list)  # rdflib terms, None when unbound
    boolean: bool = False
    graph: rdflib.Graph | None = None
    engine: str = "rdflib"

    def as_dicts(self) -> list[dict[str, str]]:
        """Rows as {var: string value}, unbound variables left out (for JSON APIs and the CLI)."""
        return [{v: str(t) for v, t in zip(self.vars, row) if t is not None} for row in self.rows]


@lru_cache(maxsize=512)
def parse_query(text: str):
    """rdflib's prepared query (algebra); raises QueryError with the parser's message.

    Anything that would make the server fetch remote data (SERVICE, FROM, FROM NAMED) is refused.
    """
    try:
        prepared = prepareQuery(text)
    except ParseException as e:
        raise QueryError(f"SPARQL syntax error: {e}") from None
    except Exception as e:  # rdflib raises plain Exceptions for unknown prefixes etc.
        raise QueryError(f"invalid SPARQL query: {e}") from None
    if prepared.algebra.get("datasetClause"):
        raise QueryError("FROM / FROM NAMED are not supported: the default graph is the union of all "
                         "robots; use GRAPH <robot ontology IRI> for one robot")
    _refuse_service(prepared.algebra)
    return prepared


def parse_update(text: str):
    """rdflib's translated update; QueryError if malformed or if it would fetch remote data (LOAD, SERVICE)."""
    try:
        update = translateUpdate(parseUpdate(text))
    except ParseException as e:
        raise QueryError(f"SPARQL update syntax error: {e}") from None
    except Exception as e:
        raise QueryError(f"invalid SPARQL update: {e}") from None
    if any(op.name == "Load" for op in update.algebra):
        raise QueryError("LOAD is not supported: the server does not fetch remote data")
    _refuse_service(update.algebra)
    return update


def _refuse_service(algebra) -> None:
    if _contains(algebra, "ServiceGraphPattern"):
        raise QueryError("SERVICE (federated query) is not supported: the server does not fetch remote data")


def _contains(node, name: str) -> bool:
    if isinstance(node, CompValue):
        return node.name == name or any(_contains(v, name) for v in node.values())
    if isinstance(node, (list, tuple)):
        return any(_contains(v, name) for v in node)
    return False


class _DeadlineGraph(TripleLiteRDFlibGraph):
    """The whole world as an rdflib graph whose triples() stops the query past `deadline`."""

    deadline = math.inf

    def triples(self, triple):
        if time.monotonic() > self.deadline:
            raise QueryTimeout("query timed out")
        for i, t in enumerate(super().triples(triple)):
            if not i & 255 and time.monotonic() > self.deadline:
                raise QueryTimeout("query timed out")
            yield t


class SparqlEngine:
    """Runs SPARQL over one owlready2 world. Not thread-safe: callers serialise access."""

    def __init__(self, world):
        self.world = world
        self.db = world.graph.db
        self.graph = _DeadlineGraph(store=world.as_rdflib_graph().store)
        self.graph.triplelite = world.graph
        self.graph.onto = None
        self._not_native: set[str] = set()

    @contextmanager
    def _deadline(self, timeout: float):
        deadline = time.monotonic() + timeout
        self.graph.deadline = deadline
        self.db.set_progress_handler(lambda: time.monotonic() > deadline, 20_000)
        try:
            yield
        except Exception as e:
            if time.monotonic() > deadline:  # sqlite "interrupted", or rdflib wrapping our error
                raise QueryTimeout(f"query stopped after its {timeout:g} s timeout") from e
            raise
        finally:
            self.db.set_progress_handler(None, 0)
            self.graph.deadline = math.inf

    def query(self, text: str, timeout: float = 10.0, engine: str = "auto") -> Result:
        """Evaluate a SPARQL 1.1 query; QueryError if malformed, QueryTimeout past `timeout` s.

        engine="rdflib" skips the native engine (to compare the two)."""
        prepared = parse_query(text)
        with self._deadline(timeout):
            use_native = engine == "auto" and prepared.algebra.name == "SelectQuery"
            native = self._native(text) if use_native else None
            if native is not None:
                try:
                    return self._run_native(native)
                except sqlite3.OperationalError:
                    if time.monotonic() > self.graph.deadline:
                        raise
                    self._not_native.add(text)  # owlready2 translated it to SQL SQLite rejects
            return self._run_rdflib(prepared)

    def update(self, text: str, timeout: float = 10.0) -> None:
        """Apply a SPARQL 1.1 update to the world (the caller commits or rolls back).

        Inserted triples go to ontology UPDATES_IRI, so they outlive re-populating a robot;
        deletions apply wherever the triples are.
        """
        update = parse_update(text)
        with self._deadline(timeout), self.world.get_ontology(UPDATES_IRI):
            self.graph.update(update)

    def _native(self, text: str) -> PreparedSelectQuery | None:
        if text in self._not_native:
            return None
        try:
            prepared = self.world.prepare_sparql(text, False)
        except Exception:  # a construct the native translator does not support
            return None
        return prepared if type(prepared) is PreparedSelectQuery else None

    def _run_native(self, prepared: PreparedSelectQuery) -> Result:
        names = [c[1:] for c in prepared.column_names]
        types = prepared.column_types
        rows = []
        for raw in prepared.execute_raw():
            row, i = [], 0
            while i < len(raw):
                if types[i] == "objs":
                    row.append(self._resource(raw[i]))
                    i += 1
                elif types[i] == "onto":
                    row.append(URIRef(self.world.graph.c_2_onto[raw[i]].base_iri))
                    i += 1
                else:
                    value, d = raw[i], raw[i + 1]
                    row.append(self._resource(value) if d == "o" else self._literal(value, d))
                    i += 2
            rows.append(tuple(row))
        return Result("bindings", names, rows, engine="owlready2")

    def _resource(self, storid):
        if storid is None:
            return None
        return URIRef(self.world._unabbreviate(storid)) if storid > 0 else BNode(f"r{-storid}")

    def _literal(self, value, d):
        if value is None:
            return None
        if isinstance(d, str) and d.startswith("@"):
            return Literal(str(value), lang=d[1:])
        datatype = self.world._unabbreviate(d) if d else XSD + "string"
        if datatype == XSD + "string":  # a simple literal, as rdflib and other stores give it
            return Literal(str(value))
        if datatype == XSD + "boolean":
            return Literal("true" if value in (1, True, "true", "1") else "false", datatype=URIRef(datatype))
        return Literal(str(value), datatype=URIRef(datatype))

    def _run_rdflib(self, prepared) -> Result:
        res = self.graph.query(prepared)
        if res.type == "ASK":
            return Result("boolean", boolean=bool(res.askAnswer))
        if res.type in ("CONSTRUCT", "DESCRIBE"):
            graph = rdflib.Graph()
            for t in res.graph:
                graph.add(t)
            return Result("graph", graph=graph)
        names = [str(v) for v in res.vars]
        return Result("bindings", names, [tuple(r) for r in res])


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


def offers_for(result: Result) -> list[str]:
    """Media types a result can be serialised as, preferred first."""
    if result.kind == "graph":
        return list(GRAPH_TYPES)
    return list(SELECT_TYPES)


def serialize(result: Result, media_type: str) -> bytes:
    """Serialise a result as `media_type` (one of offers_for(result))."""
    if result.kind == "graph":
        return result.graph.serialize(format=GRAPH_TYPES[media_type], encoding="utf-8")
    return _WRITERS[SELECT_TYPES[media_type]](result)


def _json_term(t) -> dict:
    if isinstance(t, URIRef):
        return {"type": "uri", "value": str(t)}
    if isinstance(t, BNode):
        return {"type": "bnode", "value": str(t)}
    out = {"type": "literal", "value": str(t)}
    if t.language:
        out["xml:lang"] = t.language
    elif t.datatype and str(t.datatype) != XSD + "string":
        out["datatype"] = str(t.datatype)
    return out


def to_json(result: Result) -> bytes:
    """W3C SPARQL 1.1 Query Results JSON Format."""
    if result.kind == "boolean":
        doc = {"head": {}, "boolean": result.boolean}
    else:
        bindings = [{v: _json_term(t) for v, t in zip(result.vars, row) if t is not None} for row in result.rows]
        doc = {"head": {"vars": result.vars}, "results": {"bindings": bindings}}
    return json.dumps(doc, ensure_ascii=False).encode("utf-8")


def to_xml(result: Result) -> bytes:
    """W3C SPARQL Query Results XML Format."""
    root = ET.Element(f"{{{SRX_NS}}}sparql")
    head = ET.SubElement(root, f"{{{SRX_NS}}}head")
    if result.kind == "boolean":
        ET.SubElement(root, f"{{{SRX_NS}}}boolean").text = "true" if result.boolean else "false"
    else:
        for v in result.vars:
            ET.SubElement(head, f"{{{SRX_NS}}}variable", name=v)
        results = ET.SubElement(root, f"{{{SRX_NS}}}results")
        for row in result.rows:
            res = ET.SubElement(results, f"{{{SRX_NS}}}result")
            for v, t in zip(result.vars, row):
                if t is None:
                    continue
                b = ET.SubElement(res, f"{{{SRX_NS}}}binding", name=v)
                if isinstance(t, URIRef):
                    ET.SubElement(b, f"{{{SRX_NS}}}uri").text = str(t)
                elif isinstance(t, BNode):
                    ET.SubElement(b, f"{{{SRX_NS}}}bnode").text = str(t)
                else:
                    lit = ET.SubElement(b, f"{{{SRX_NS}}}literal")
                    lit.text = str(t)
                    if t.language:
                        lit.set("{http://www.w3.org/XML/1998/namespace}lang", t.language)
                    elif t.datatype and str(t.datatype) != XSD + "string":
                        lit.set("datatype", str(t.datatype))
    return ET.tostring(root, encoding="utf-8", xml_declaration=True)


def _csv_value(t) -> str:
    if t is None:
        return ""
    return f"_:{t}" if isinstance(t, BNode) else str(t)


def to_csv(result: Result) -> bytes:
    """W3C SPARQL 1.1 Query Results CSV Format (lexical values, CRLF, RFC 4180 quoting)."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\r\n")
    if result.kind == "boolean":
        w.writerow(["_askResult"])
        w.writerow(["true" if result.boolean else "false"])
    else:
        w.writerow(result.vars)
        for row in result.rows:
            w.writerow([_csv_value(t) for t in row])
    return buf.getvalue().encode("utf-8")


def _tsv_value(t) -> str:
    if t is None:
        return ""
    if isinstance(t, BNode):
        return f"_:{t}"
    if isinstance(t, Literal) and t.datatype == XSD_STRING:
        t = Literal(str(t))
    return t.n3().replace("\t", "\\t")


def to_tsv(result: Result) -> bytes:
    """W3C SPARQL 1.1 Query Results TSV Format (terms in Turtle/N-Triples syntax)."""
    if result.kind == "boolean":
        lines = ["?_askResult", "true" if result.boolean else "false"]
    else:
        lines = ["\t".join(f"?{v}" for v in result.vars)]
        lines += ["\t".join(_tsv_value(t) for t in row) for row in result.rows]
    return ("\n".join(lines) + "\n").encode("utf-8")


ET.register_namespace("", SRX_NS)
_WRITERS = {"json": to_json, "xml": to_xml, "csv": to_csv, "tsv": to_tsv}
