"""Run the W3C SPARQL 1.0/1.1 query-evaluation tests (tests/w3c, from w3c/rdf-tests) over HTTP.

For each test: every data file goes into its own named graph (graph IRI = the file's IRI) with an
authorised INSERT DATA, the query goes to the endpoint with the SPARQL Protocol's
default-graph-uri / named-graph-uri naming the test's dataset (queries with their own FROM are
sent as they are), the answer is compared with the expected one (blank nodes up to renaming,
order only where the query has ORDER BY), and the graphs are dropped again.
Also a command: `python tests/w3c_harness.py URL [TOKEN]` prints the pass count for any endpoint.
"""
from __future__ import annotations

import csv
import io
import sys
import urllib.error
import urllib.parse
import urllib.request
from dataclasses import dataclass
from pathlib import Path

import pyoxigraph as ox

ROOT = Path(__file__).resolve().parent / "w3c"
BASE = "https://w3c.github.io/rdf-tests/sparql/"
RS = "http://www.w3.org/2001/sw/DataAccess/tests/result-set#"
EMPTY = "urn:x-urdfkb-test:empty"
_LIST = """PREFIX mf: <http://www.w3.org/2001/sw/DataAccess/tests/test-manifest#>
PREFIX qt: <http://www.w3.org/2001/sw/DataAccess/tests/test-query#>
PREFIX rdf: <http://www.w3.org/1999/02/22-rdf-syntax-ns#>
SELECT ?t ?type ?query ?result (GROUP_CONCAT(DISTINCT STR(?d); separator=" ") AS ?data)
       (GROUP_CONCAT(DISTINCT STR(?n); separator=" ") AS ?named) WHERE {
  ?m mf:entries/rdf:rest*/rdf:first ?t . ?t a ?type ; mf:action ?a ; mf:result ?result . ?a qt:query ?query .
  OPTIONAL { ?a qt:data ?d } OPTIONAL { ?a qt:graphData ?n }
  FILTER(?type IN (mf:QueryEvaluationTest, mf:CSVResultFormatTest))
} GROUP BY ?t ?type ?query ?result"""


@dataclass(frozen=True)
class Case:
    id: str
    query: str
    result: str
    data: tuple[str, ...]
    named: tuple[str, ...]

    def __str__(self) -> str:
        return self.id


def _path(iri: str) -> Path:
    return ROOT / iri[len(BASE):]


def cases() -> list[Case]:
    out = []
    for manifest in sorted(ROOT.glob("sparql1*/*/manifest.ttl")):
        store = ox.Store()
        store.load(path=str(manifest), format=ox.RdfFormat.TURTLE, base_iri=BASE + str(manifest.relative_to(ROOT)))
        for r in _select(store, _LIST):
            out.append(Case("/".join(r["t"].value.split("/")[-3:]), r["query"].value, r["result"].value,
                            tuple(r["data"].value.split() if r["data"] else ()),
                            tuple(r["named"].value.split() if r["named"] else ())))
    return sorted(out, key=str)


def _select(store: ox.Store, query: str) -> ox.QuerySolutions:
    answer = store.query(query)
    assert isinstance(answer, ox.QuerySolutions), query
    return answer


def _parse(iri: str) -> list[ox.Triple]:
    fmt = {".ttl": ox.RdfFormat.TURTLE, ".rdf": ox.RdfFormat.RDF_XML, ".nt": ox.RdfFormat.N_TRIPLES}[_path(iri).suffix]
    return [q.triple for q in ox.parse(path=str(_path(iri)), format=fmt, base_iri=iri)]


class Endpoint:
    """A SPARQL 1.1 Protocol endpoint (query and update at the same URL, as urdfkb and Oxigraph's /query)."""

    def __init__(self, query_url: str, update_url: str | None = None, token: str | None = None):
        self.query_url, self.update_url, self.token = query_url, update_url or query_url, token

    def _send(self, url: str, body: bytes, ctype: str, accept: str | None = None):
        headers = {"Content-Type": ctype}
        if accept:
            headers["Accept"] = accept
        if self.token:
            headers["Authorization"] = f"Bearer {self.token}"
        req = urllib.request.Request(url, data=body, headers=headers, method="POST")
        try:
            with urllib.request.urlopen(req, timeout=30) as r:
                return r.status, r.headers.get("Content-Type", ""), r.read()
        except urllib.error.HTTPError as e:
            return e.code, e.headers.get("Content-Type", ""), e.read()

    def update(self, text: str) -> None:
        status, _, body = self._send(self.update_url, text.encode(), "application/sparql-update")
        if status not in (200, 204):
            raise RuntimeError(f"update refused ({status}): {body[:300]!r}")

    def query(self, text: str, accept: str, default: list[str], named: list[str]):
        params = [("default-graph-uri", g) for g in default] + [("named-graph-uri", g) for g in named]
        url = self.query_url + ("?" + urllib.parse.urlencode(params) if params else "")
        return self._send(url, text.encode(), "application/sparql-query", accept)


def _nt(triples) -> str:
    return "\n".join(f"{t.subject} {t.predicate} {t.object} ." for t in triples)


def run(case: Case, endpoint: Endpoint) -> str | None:
    """None if the endpoint answers `case` as expected, else what differs."""
    text = _path(case.query).read_text(encoding="utf-8")
    query = f"BASE <{case.query}>\n{text}"
    files = list(dict.fromkeys(case.data + case.named + tuple(_from_clauses(query))))
    has_dataset = bool(_from_clauses(query))
    default, named = ([], []) if has_dataset else (list(case.data) or [EMPTY], list(case.named))
    files = list(dict.fromkeys(files + default))
    for f in files:
        triples = [] if f == EMPTY else _parse(f)
        if triples:
            endpoint.update(f"INSERT DATA {{ GRAPH <{f}> {{ {_nt(triples)} }} }}")
        else:  # an empty graph must exist all the same (urdfkb refuses datasets naming no graph of its)
            endpoint.update(f"INSERT DATA {{ GRAPH <{f}> {{ <urn:x:s> <urn:x:p> <urn:x:o> }} }}; "
                            f"DELETE DATA {{ GRAPH <{f}> {{ <urn:x:s> <urn:x:p> <urn:x:o> }} }}")
    try:
        expected_path = _path(case.result)
        accept = {".srx": "application/sparql-results+xml", ".srj": "application/sparql-results+json",
                  ".csv": "text/csv", ".tsv": "text/tab-separated-values"}.get(expected_path.suffix,
                                                                                    "application/n-triples, application/sparql-results+json")
        status, ctype, body = endpoint.query(query, accept, default, named)
        if status != 200:
            return f"HTTP {status}: {body[:300]!r}"
        return _compare(case, ctype.split(";")[0].strip(), body, "ORDER" in text.upper() and "ORDER BY" in " ".join(text.upper().split()))
    finally:
        for f in files:
            endpoint.update(f"DROP SILENT GRAPH <{f}>")


def _from_clauses(query: str) -> list[str]:
    from urdfkb.kb_server.sparql import scan
    found = scan(query)  # None for a prefixed name without its PREFIX: no file to load, the endpoint refuses it
    return [iri for iri in found.from_graphs + found.from_named if iri is not None]


_RESULT_FORMATS = {"application/sparql-results+json": ox.QueryResultsFormat.JSON,
                   "application/sparql-results+xml": ox.QueryResultsFormat.XML,
                   "text/csv": ox.QueryResultsFormat.CSV, "text/tab-separated-values": ox.QueryResultsFormat.TSV}


def _compare(case: Case, ctype: str, body: bytes, ordered: bool) -> str | None:
    path = _path(case.result)
    if ctype in ("application/n-triples", "text/plain"):
        got = ox.Dataset(ox.Quad(t.subject, t.predicate, t.object) for t in
                         (q.triple for q in ox.parse(body, format=ox.RdfFormat.N_TRIPLES)))
        want = ox.Dataset(ox.Quad(t.subject, t.predicate, t.object) for t in _parse(case.result))
        for d in (got, want):
            d.canonicalize(ox.CanonicalizationAlgorithm.UNSTABLE)
        return None if got == want else f"graph differs: got {len(got)} triples, want {len(want)}"
    if path.suffix == ".csv":  # lossy: pyoxigraph will not parse it back into terms, so compare the text
        def table(data: bytes):  # rows as sorted (column, value) lists: SELECT * fixes no column order
            head, *rows = list(csv.reader(io.StringIO(data.decode("utf-8"))))
            return sorted(sorted((h, "_:" if v.startswith("_:") else v) for h, v in zip(head, r)) for r in rows)
        return None if table(body) == table(path.read_bytes()) else f"CSV differs: {body[:300]!r}"
    got = _solutions(body, _RESULT_FORMATS[ctype])
    if path.suffix in (".ttl", ".rdf"):
        want = _rdf_result_set(case.result)
    else:
        want = _solutions(path.read_bytes(), ox.QueryResultsFormat.from_extension(path.suffix[1:]))
    if isinstance(got, bool) or isinstance(want, bool):
        return None if got == want else f"boolean {got} != {want}"
    return None if _same_rows(got, want, ordered) else f"rows differ: got {got[:5]}..., want {want[:5]}..."


def _solutions(data: bytes, fmt):
    parsed = ox.parse_query_results(data, format=fmt)
    if isinstance(parsed, ox.QueryBoolean):
        return bool(parsed)
    names = [v.value for v in parsed.variables]
    return [{n: s[n] for n in names if s[n] is not None} for s in parsed]


def _rdf_result_set(iri: str):
    store = ox.Store()
    store.extend(ox.Quad(t.subject, t.predicate, t.object) for t in _parse(iri))
    ask = list(_select(store, f"SELECT ?b {{ ?r <{RS}boolean> ?b }}"))
    if ask:
        return ask[0]["b"].value == "true"
    rows: dict[ox.BlankNode, tuple[dict[str, ox.NamedNode | ox.BlankNode | ox.Literal], int]] = {}
    for r in _select(store, f"""SELECT ?s ?v ?val ?i WHERE {{ ?rs <{RS}solution> ?s .
            OPTIONAL {{ ?s <{RS}binding> ?b . ?b <{RS}variable> ?v ; <{RS}value> ?val }} OPTIONAL {{ ?s <{RS}index> ?i }} }}"""):
        row = rows.setdefault(r["s"], ({}, int(r["i"].value) if r["i"] else 0))[0]
        if r["v"] is not None:
            row[r["v"].value] = r["val"]
    return [row for row, _ in sorted(rows.values(), key=lambda x: x[1])]


def _same_rows(got: list[dict], want: list[dict], ordered: bool) -> bool:
    """Equal multisets (sequences if `ordered`) of rows, blank nodes up to a consistent renaming."""
    if len(got) != len(want):
        return False

    def key(row):  # blank nodes masked
        return tuple(sorted((k, "_:" if isinstance(v, ox.BlankNode) else str(v)) for k, v in row.items()))

    if not ordered:
        got, want = sorted(got, key=key), sorted(want, key=key)
    if [key(r) for r in got] != [key(r) for r in want] and ordered:
        return False
    if sorted(map(key, got)) != sorted(map(key, want)):
        return False
    return _bnode_match(got, want, {}, set())


def _bnode_match(got, want, mapping, used) -> bool:
    if not got:
        return True
    first = got[0]
    for j, cand in enumerate(want):
        m, ok = dict(mapping), set(first) == set(cand)
        for k in first if ok else ():
            a, b = first[k], cand[k]
            if isinstance(a, ox.BlankNode) and isinstance(b, ox.BlankNode):
                if m.setdefault(a, b) != b or (a not in mapping and b in used):
                    ok = False
                    break
            elif a != b:
                ok = False
                break
        if ok and _bnode_match(got[1:], want[:j] + want[j + 1:], m, used | set(m.values())):
            return True
    return False


if __name__ == "__main__":
    url = sys.argv[1]
    ep = Endpoint(url, sys.argv[2] if len(sys.argv) > 2 and sys.argv[2].startswith("http") else None,
                  sys.argv[-1] if len(sys.argv) > 2 and not sys.argv[-1].startswith("http") else None)
    passed, failed = 0, []
    for c in cases():
        try:
            problem = run(c, ep)
        except Exception as e:  # noqa: BLE001 - a command-line report
            problem = f"error: {e}"
        if problem:
            failed.append(f"{c}: {problem[:200]}")
        else:
            passed += 1
    print("\n".join(failed))
    print(f"{passed} passed, {len(failed)} failed")
