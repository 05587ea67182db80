"""Every RDF and SPARQL results format urdfkb writes, in one table: name, file extension, media types, writers.

RDF syntaxes serve exports (`urdfkb populate --format`, GET /robots/<name>.<extension>), CONSTRUCT and
DESCRIBE answers and the service description; results formats serve SELECT and ASK answers (/sparql,
/queries/<name>, `urdfkb query --format`). A format answers to its media type and its aliases.
"""
from __future__ import annotations

from typing import NamedTuple

import pyoxigraph as ox


class RdfFormat(NamedTuple):
    name: str                 # `urdfkb populate --format` value, and pipeline.knowledge.export.export_robot's fmt
    extension: str            # `urdfkb populate`'s default output suffix, and GET /robots/<name>.<extension>
    media_type: str           # Content-Type of a download or an answer
    aliases: tuple[str, ...]  # other media types a client may ask for it by
    rdflib: str               # rdflib's serializer name
    oxigraph: ox.RdfFormat    # Oxigraph's writer


class ResultsFormat(NamedTuple):
    name: str                          # `urdfkb query --format` value
    media_type: str
    aliases: tuple[str, ...]
    oxigraph: ox.QueryResultsFormat


RDF_XML = RdfFormat("rdfxml", "owl", "application/rdf+xml", (), "xml", ox.RdfFormat.RDF_XML)
TURTLE = RdfFormat("turtle", "ttl", "text/turtle", (), "turtle", ox.RdfFormat.TURTLE)
N_TRIPLES = RdfFormat("ntriples", "nt", "application/n-triples", ("text/plain",), "nt", ox.RdfFormat.N_TRIPLES)

EXPORT_FORMATS = (RDF_XML, TURTLE, N_TRIPLES)  # RDF/XML first: the default export, which Protégé opens
GRAPH_FORMATS = (TURTLE, RDF_XML, N_TRIPLES)  # Turtle first: the answer when the client names no preference
RESULTS_FORMATS = (
    ResultsFormat("json", "application/sparql-results+json", ("application/json",), ox.QueryResultsFormat.JSON),
    ResultsFormat("xml", "application/sparql-results+xml", ("application/xml",), ox.QueryResultsFormat.XML),
    ResultsFormat("csv", "text/csv", (), ox.QueryResultsFormat.CSV),
    ResultsFormat("tsv", "text/tab-separated-values", (), ox.QueryResultsFormat.TSV),
)

BY_NAME = {f.name: f for f in EXPORT_FORMATS}
BY_EXTENSION = {f.extension: f for f in EXPORT_FORMATS}
RESULTS_BY_NAME = {f.name: f for f in RESULTS_FORMATS}
# What content negotiation offers, in the order it prefers on a tie: each format's media type, then its aliases.
GRAPH_MEDIA = {media: f for f in GRAPH_FORMATS for media in (f.media_type, *f.aliases)}
RESULTS_MEDIA = {media: f for f in RESULTS_FORMATS for media in (f.media_type, *f.aliases)}
