"""The export formats, in one table: `--format` name, file extension, media type (CLI, store, HTTP)."""
from __future__ import annotations

from typing import NamedTuple


class ExportFormat(NamedTuple):
    name: str        # `urdfkb populate --format` value, and pipeline.export.export_robot's fmt
    extension: str   # `urdfkb populate`'s default output suffix, and GET /robots/<name>.<extension>
    media_type: str  # Content-Type of the download


EXPORT_FORMATS = (ExportFormat("rdfxml", "owl", "application/rdf+xml"),
                  ExportFormat("turtle", "ttl", "text/turtle"),
                  ExportFormat("ntriples", "nt", "application/n-triples"))
BY_NAME = {f.name: f for f in EXPORT_FORMATS}
BY_EXTENSION = {f.extension: f for f in EXPORT_FORMATS}
