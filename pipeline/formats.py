"""The export formats, in one table: `--format` name, file extension, media type, rdflib serializer
(CLI, export, store, HTTP)."""
from __future__ import annotations

from typing import NamedTuple


class ExportFormat(NamedTuple):
    name: str        # `urdfkb populate --format` value, and pipeline.export.export_robot's fmt
    extension: str   # `urdfkb populate`'s default output suffix, and GET /robots/<name>.<extension>
    media_type: str  # Content-Type of the download
    rdflib: str      # rdflib's serializer name


EXPORT_FORMATS = (ExportFormat("rdfxml", "owl", "application/rdf+xml", "xml"),
                  ExportFormat("turtle", "ttl", "text/turtle", "turtle"),
                  ExportFormat("ntriples", "nt", "application/n-triples", "nt"))
BY_NAME = {f.name: f for f in EXPORT_FORMATS}
BY_EXTENSION = {f.extension: f for f in EXPORT_FORMATS}
