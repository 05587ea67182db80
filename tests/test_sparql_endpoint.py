"""SPARQL 1.1 Protocol at /sparql on a live waitress server, via SPARQLWrapper, rdflib and raw HTTP."""
import csv
import io
import json
import urllib.parse
from xml.dom.minidom import Document, Text

import pytest
import rdflib
from rdflib.plugins.stores.sparqlstore import SPARQLStore
from rdflib.query import ResultRow
from SPARQLWrapper import JSON, POST, POSTDIRECTLY, TURTLE, XML, SPARQLWrapper

from tests.kb_fixtures import PR2, copied, http, served
from urdfkb.kb_server.store import Store

P = "PREFIX core: <https://w3id.org/urdfkb/core#> PREFIX rdfs: <http://www.w3.org/2000/01/rdf-schema#> "
KINECT = "https://w3id.org/urdfkb/robot/pr2#comp_kinect"
CAMERAS = P + "SELECT ?c WHERE { ?c a/rdfs:subClassOf* core:Camera } ORDER BY ?c"
TOKEN = "s3cret"


@pytest.fixture(scope="module")
def url(pr2_kb, tmp_path_factory):
    store = Store(copied(pr2_kb, tmp_path_factory.mktemp("kb")))
    with served(store, token=TOKEN, query_timeout=1.0) as base:
        yield base + "/sparql"
    store.close()


def wrapper(url, query, fmt, method="GET"):
    sw = SPARQLWrapper(url)
    sw.setQuery(query)
    sw.setReturnFormat(fmt)
    if method != "GET":
        sw.setMethod(POST)
        if method == "POSTDIRECTLY":
            sw.setRequestMethod(POSTDIRECTLY)
    return sw.query()


@pytest.mark.parametrize("method", ["GET", "POST", "POSTDIRECTLY"])
def test_select_json_and_xml_with_sparqlwrapper(url, method):
    res = wrapper(url, CAMERAS, JSON, method)
    assert res.info()["content-type"].startswith("application/sparql-results+json")
    cams = [b["c"]["value"] for b in res.convert()["results"]["bindings"]]
    assert len(cams) == 4 and KINECT in cams  # RGBDCamera counts as a Camera
    doc = wrapper(url, CAMERAS, XML, method).convert()
    assert isinstance(doc, Document)
    assert sorted(t.data for u in doc.getElementsByTagName("uri") if isinstance(t := u.firstChild, Text)) == sorted(cams)


def test_ask_construct_describe_minus(url):
    assert wrapper(url, P + f"ASK {{ <{KINECT}> a core:RGBDCamera }}", JSON).convert()["boolean"] is True
    assert wrapper(url, P + "ASK { ?x a core:Toaster }", XML).convert().getElementsByTagName("boolean")[0].firstChild.data == "false"
    g = wrapper(url, P + "CONSTRUCT { ?c core:isMountedOn ?m } WHERE { ?c core:isMountedOn ?m }", TURTLE).convert()
    graph = rdflib.Graph().parse(data=g, format="turtle")
    assert len(graph) == len(PR2.components)
    status, ctype, body = http("GET", url + "?" + urllib.parse.urlencode({"query": f"DESCRIBE <{KINECT}>"}),
                               headers={"Accept": "application/n-triples"})
    assert status == 200 and ctype.startswith("application/n-triples")
    assert (rdflib.URIRef(KINECT), rdflib.RDF.type, rdflib.URIRef("https://w3id.org/urdfkb/core#RGBDCamera")) in \
        rdflib.Graph().parse(data=body, format="nt")
    minus = P + "SELECT ?c WHERE { ?c a/rdfs:subClassOf* core:Camera MINUS { ?c a core:MonocularCamera } }"
    assert len(wrapper(url, minus, JSON).convert()["results"]["bindings"]) == 2


def test_rdflib_sparqlstore(url):
    g = rdflib.Graph(store=SPARQLStore(url))
    rows = [row for row in g.query(CAMERAS) if isinstance(row, ResultRow)]
    assert len(rows) == 4 and rdflib.URIRef(KINECT) in [r[0] for r in rows]
    ((conf,),) = [row for row in g.query(P + f"SELECT ?v WHERE {{ <{KINECT}> core:confidence ?v }}")
                  if isinstance(row, ResultRow)]
    assert isinstance(conf, rdflib.Literal) and conf.datatype == rdflib.XSD.decimal and str(conf) == "0.93"


def get(url, query, accept=None):
    return http("GET", url + "?" + urllib.parse.urlencode({"query": query}), headers={"Accept": accept} if accept else {})


def test_csv_tsv_and_q_values(url):
    q = P + f"SELECT ?c ?v WHERE {{ ?c core:confidence ?v FILTER(?c = <{KINECT}>) }}"
    status, ctype, body = get(url, q, "text/csv")
    assert status == 200 and ctype.startswith("text/csv")
    assert list(csv.reader(io.StringIO(body.decode()))) == [["c", "v"], [KINECT, "0.93"]]
    status, ctype, body = get(url, q, "text/tab-separated-values")
    assert ctype.startswith("text/tab-separated-values")
    assert body.decode().splitlines() == ["?c\t?v", f'<{KINECT}>\t0.93']  # Turtle's short form of an xsd:decimal
    assert get(url, q, "text/csv;q=0.2, application/sparql-results+xml;q=0.9")[1].startswith("application/sparql-results+xml")
    assert get(url, q, "text/csv;q=0, */*;q=0.1")[1].startswith("application/sparql-results+json")
    assert get(url, q)[1].startswith("application/sparql-results+json")
    assert get(url, q, "image/png")[0] == 406


def test_unknown_iri_is_empty_and_malformed_is_400(url):
    status, _, body = get(url, "SELECT ?p ?o WHERE { <urn:never:seen> ?p ?o }")
    assert status == 200 and json.loads(body)["results"]["bindings"] == []
    status, ctype, body = get(url, "SELECT ?x WHERE { ?x a }")
    assert status == 400 and ctype.startswith("text/plain") and b"syntax error" in body
    assert get(url, "SELECT ?x WHERE { ?x nope:a ?y }")[0] == 400


def test_remote_fetching_is_refused(url):
    for q in ("SELECT * WHERE { SERVICE <http://127.0.0.1:9/sparql> { ?s ?p ?o } }",
              "SELECT * FROM <http://127.0.0.1:9/data.ttl> WHERE { ?s ?p ?o }"):
        status, _, body = get(url, q)
        assert status == 400 and b"remote data" in body
    h = {"Content-Type": "application/sparql-update", "Authorization": f"Bearer {TOKEN}"}
    status, _, body = http("POST", url, b"LOAD <http://127.0.0.1:9/data.ttl>", h)
    assert status == 400 and b"LOAD" in body


def test_named_graphs_are_robot_ontologies(url):
    q = "SELECT (COUNT(*) AS ?n) WHERE { GRAPH <https://w3id.org/urdfkb/robot/pr2#> { ?c a <https://w3id.org/urdfkb/core#Lidar> } }"
    assert json.loads(get(url, q)[2])["results"]["bindings"][0]["n"]["value"] == "2"


@pytest.mark.slow
def test_timeout_is_an_error_and_the_server_keeps_serving(url):
    status, _, body = get(url, "SELECT (COUNT(*) AS ?n) WHERE { ?a ?b ?c . ?d ?e ?f . ?g ?h ?i }")
    assert status == 503 and b"timeout" in body
    assert get(url, CAMERAS)[0] == 200


def test_updates_need_the_token(url):
    insert = P + f"INSERT DATA {{ <{KINECT}> rdfs:comment \"checked\" }}"
    ask = P + f"ASK {{ <{KINECT}> rdfs:comment \"checked\" }}"
    h = {"Content-Type": "application/sparql-update"}
    assert http("POST", url, insert.encode(), h)[0] == 403
    assert http("POST", url, insert.encode(), {**h, "Authorization": "Bearer wrong"})[0] == 403
    assert json.loads(get(url, ask)[2])["boolean"] is False
    assert http("POST", url, insert.encode(), {**h, "Authorization": f"Bearer {TOKEN}"})[0] == 204
    assert json.loads(get(url, ask)[2])["boolean"] is True
    form = urllib.parse.urlencode({"update": "DELETE WHERE { ?s <http://www.w3.org/2000/01/rdf-schema#comment> \"checked\" }"})
    fh = {"Content-Type": "application/x-www-form-urlencoded", "Authorization": f"Bearer {TOKEN}"}
    assert http("POST", url, form.encode(), fh)[0] == 204
    assert json.loads(get(url, ask)[2])["boolean"] is False
    assert http("POST", url, b"INSERT DATA {", {**h, "Authorization": f"Bearer {TOKEN}"})[0] == 400


def test_service_description(url):
    status, ctype, body = http("GET", url)
    assert status == 200 and ctype.startswith("text/turtle")
    g = rdflib.Graph().parse(data=body, format="turtle")
    sd = rdflib.Namespace("http://www.w3.org/ns/sparql-service-description#")
    assert (None, sd.supportedLanguage, sd.SPARQL11Query) in g
    assert (None, sd.name, rdflib.URIRef("https://w3id.org/urdfkb/robot/pr2#")) in g
    assert http("POST", url, b"SELECT * {}", {"Content-Type": "text/plain"})[0] == 415
