"""Mirror robots into a SPARQL 1.1 Graph Store HTTP Protocol endpoint (Fuseki, Oxigraph, GraphDB).

Each robot is one named graph whose IRI is the robot's ontology IRI: PUT replaces it, DELETE
drops it. The URL is the store's graph-store endpoint, e.g. http://host:7878/store (Oxigraph)
or http://host:3030/ds/data (Fuseki); graphs are addressed indirectly (`?graph=<iri>`).
"""
from __future__ import annotations

import urllib.error
import urllib.parse
import urllib.request

import rdflib

from urdfkb.pipeline.knowledge import rdf
from urdfkb.pipeline.errors import UrdfkbError
from urdfkb.pipeline.knowledge.formats import N_TRIPLES
from urdfkb.settings import REMOTE_TIMEOUT


class RemoteError(UrdfkbError, RuntimeError):
    """The remote store could not be reached or refused the request (a failed mirror is its job's
    `mirror_failed` state; a request that met it would get 502)."""

    status = 502


class RemoteStore:
    """A Graph Store Protocol endpoint; `timeout` bounds each request (seconds)."""

    def __init__(self, url: str, timeout: float = REMOTE_TIMEOUT):
        parts = urllib.parse.urlsplit(url)
        if parts.scheme not in ("http", "https") or not parts.netloc:
            raise ValueError(f"remote store URL must be http(s)://host[:port]/path, not {url!r}")
        self.url = url
        self.timeout = timeout

    def _graph_url(self, graph_iri: str) -> str:
        sep = "&" if urllib.parse.urlsplit(self.url).query else "?"
        return f"{self.url}{sep}{urllib.parse.urlencode({'graph': graph_iri})}"

    def _send(self, method: str, graph_iri: str, body: bytes | None = None, ok_missing: bool = False) -> None:
        headers = {"Content-Type": N_TRIPLES.media_type} if body is not None else {}
        req = urllib.request.Request(self._graph_url(graph_iri), data=body, method=method, headers=headers)
        try:
            with urllib.request.urlopen(req, timeout=self.timeout):
                return
        except urllib.error.HTTPError as e:
            if ok_missing and e.code == 404:
                return
            detail = e.read(500).decode("utf-8", "replace").strip()
            raise RemoteError(f"{method} {graph_iri} at {self.url}: HTTP {e.code} {detail}") from None
        except (urllib.error.URLError, OSError) as e:
            raise RemoteError(f"{method} {graph_iri} at {self.url}: {getattr(e, 'reason', e)}") from None

    def put_graph(self, graph_iri: str, graph: rdflib.Graph) -> None:
        """Replace named graph `graph_iri` with `graph`."""
        self._send("PUT", graph_iri, rdf.to_ntriples(graph))

    def delete_graph(self, graph_iri: str) -> None:
        """Drop named graph `graph_iri` (no error if it is already absent)."""
        self._send("DELETE", graph_iri, ok_missing=True)
