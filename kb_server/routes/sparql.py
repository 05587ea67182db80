"""The SPARQL 1.1 Protocol at /sparql: queries (GET, form POST, direct POST), updates (POST, with the token),
and without an operation the service description (or, for a browser, the query page)."""
from __future__ import annotations

import rdflib
from flask import Blueprint, Response, request
from rdflib.namespace import RDF

from urdfkb.kb_server import ui
from urdfkb.kb_server.errors import BadRequest, Forbidden, UnsupportedMediaType
from urdfkb.kb_server.replies import SPARQL_PATH, results
from urdfkb.kb_server.result_cache import no_cache
from urdfkb.kb_server.services import services
from urdfkb.kb_server.sparql import NotAcceptable, negotiate, protocol_dataset
from urdfkb.pipeline.knowledge.formats import GRAPH_FORMATS, GRAPH_MEDIA, RESULTS_FORMATS
from urdfkb.pipeline.knowledge.namespaces import CORE_GRAPH

SD = rdflib.Namespace("http://www.w3.org/ns/sparql-service-description#")
FORM_TYPES = ("application/x-www-form-urlencoded", "multipart/form-data")

bp = Blueprint("sparql", __name__)


@bp.route(SPARQL_PATH, methods=["GET", "POST"])
def protocol() -> Response | str:
    kb = services()
    query, update = _operation()
    if query is not None and update is not None:
        raise BadRequest("give a query or an update, not both")
    if update is not None:
        if request.method != "POST":
            raise BadRequest("updates must be sent by POST")
        if not kb.authorized():
            raise Forbidden("SPARQL updates need the server's token (Authorization: Bearer ...)")
        kb.store.update(update, kb.query_timeout)
        return Response(status=204)
    if query is None:
        if request.method == "GET" and ui.wants_html():
            return ui.sparql_page()
        if request.method == "GET":
            return _service_description()
        usage = ("POST a query (application/sparql-query or form field query) or an update "
                 "(application/sparql-update or form field update)")
        raise UnsupportedMediaType(usage) if request.mimetype not in FORM_TYPES else BadRequest(usage)
    dataset = request.values if request.mimetype in FORM_TYPES else request.args
    default, named = protocol_dataset(dataset.getlist("default-graph-uri"), dataset.getlist("named-graph-uri"))
    return results(kb.store.query(query, kb.query_timeout, request.headers.get("Accept"), default, named,
                                  fresh=no_cache(request.headers.get("Cache-Control"))))


def _operation() -> tuple[str | None, str | None]:
    """(query, update) text from a SPARQL 1.1 Protocol request (GET args, form, or direct POST)."""
    if request.method == "GET":
        return request.args.get("query"), request.args.get("update")
    if request.mimetype == "application/sparql-query":
        return request.get_data(as_text=True), None
    if request.mimetype == "application/sparql-update":
        return None, request.get_data(as_text=True)
    if request.mimetype in FORM_TYPES:
        return request.form.get("query"), request.form.get("update")
    return None, None


def _service_description() -> Response:
    kb = services()
    g = rdflib.Graph()
    g.bind("sd", SD)
    svc = rdflib.BNode()
    g.add((svc, RDF.type, SD.Service))
    g.add((svc, SD.endpoint, rdflib.URIRef(request.base_url)))
    g.add((svc, SD.supportedLanguage, SD.SPARQL11Query))
    if kb.token:
        g.add((svc, SD.supportedLanguage, SD.SPARQL11Update))
    g.add((svc, SD.feature, SD.UnionDefaultGraph))
    for fmt in (*RESULTS_FORMATS, *GRAPH_FORMATS):
        g.add((svc, SD.resultFormat, rdflib.URIRef(fmt.oxigraph.iri)))
    dataset, default = rdflib.BNode(), rdflib.BNode()
    g.add((svc, SD.defaultDataset, dataset))
    g.add((dataset, RDF.type, SD.Dataset))
    g.add((dataset, SD.defaultGraph, default))
    g.add((default, RDF.type, SD.Graph))
    for iri in [CORE_GRAPH] + [entry.ontology_iri for entry in kb.store.robots()]:
        named = rdflib.BNode()
        g.add((dataset, SD.namedGraph, named))
        g.add((named, RDF.type, SD.NamedGraph))
        g.add((named, SD.name, rdflib.URIRef(iri)))
    media = negotiate(request.headers.get("Accept"), list(GRAPH_MEDIA))
    if media is None:
        raise NotAcceptable(f"cannot answer as {request.headers.get('Accept')}; offered: {', '.join(GRAPH_MEDIA)}")
    body = g.serialize(format=GRAPH_MEDIA[media].rdflib, encoding="utf-8")
    return Response(body, 200, content_type=media + ("" if media.endswith("xml") else "; charset=utf-8"))
