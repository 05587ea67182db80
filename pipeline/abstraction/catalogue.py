"""The hardware product catalogue: public products a link's name or mesh may name, and what each is.

The small model does not know that `mid360_link` is a lidar or that `d435_link` is an RGB-D camera. The
catalogue (ontologies/products.ttl, with each entry's maker and product as its source, plus any files
named in URDFKB_PRODUCTS, separated as PATH is) says so; a matching product is shown beside the link in
the questions about it ("Product: Livox Mid-360, a lidar"), and the model still decides. A fragment
matches where a word of the name or mesh path starts (after a separator, a hyphen among them, or at a capital:
`RFsrFL`; a name in camel case is read as one word too: `vectorNav`), and, ending in a letter, where that word's
letters end ("zed" in `zed2_camera`, not in `normalized`).
"""
from __future__ import annotations

import functools
import hashlib
import os
import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import rdflib
from rdflib.namespace import DCTERMS, RDF, RDFS

from urdfkb.pipeline.errors import OntologyError
from urdfkb.pipeline.knowledge.namespaces import CORE_IRI

PRODUCTS = rdflib.Namespace("https://w3id.org/urdfkb/products#")
ENV = "URDFKB_PRODUCTS"


@dataclass(frozen=True)
class Product:
    label: str                   # "Intel RealSense D435"
    cls: str                     # its core class's local name ("RGBDCamera")
    fragments: tuple[str, ...]   # how URDFs write it, lower case
    source: str                  # maker and product


class Catalogue:
    """Products and the patterns that find them in names."""

    def __init__(self, products: Iterable[Product]):
        self.products = tuple(products)
        # what the catalogue says, for the result cache's key: an edited products file misses old results
        self.fingerprint = hashlib.sha256(repr(self.products).encode()).hexdigest()[:16]
        # longest fragment first: "d435" before "realsense" never matters, "robotiq_140" before "robotiq" and
        # "realsense_d430" (a depth module, no colour imager) before "realsense" do
        self._patterns = sorted(((len(f), re.compile(_pattern(f)), p) for p in self.products for f in p.fragments),
                                key=lambda t: -t[0])

    def match(self, names: Sequence[str]) -> Product | None:
        """The product the first of `names` (a link name, then its mesh stems) that names one names."""
        for name in names:
            # a word starts at a capital or a hyphen too (RFsrFL -> r_fsr_fl, oak-d_frame -> oak_d_frame); a name
            # written in camel case is also one word (vectorNav: vectornav); a name with no capital is read once
            texts = dict.fromkeys(t.lower().replace("-", "_") for t in (_CAMEL.sub("_", name), name))
            for _, pattern, product in self._patterns:
                if any(pattern.search(text) for text in texts):
                    return product
        return None


_CAMEL = re.compile(r"(?<=[a-z0-9])(?=[A-Z])|(?<=[A-Z])(?=[A-Z][a-z])")


def _pattern(fragment: str) -> str:
    end = "(?![a-z])" if fragment[-1].isalpha() else ""
    return f"(?<![a-z0-9]){re.escape(fragment)}{end}"


def load(sources: Iterable[str | Path]) -> Catalogue:
    """The products of Turtle files `sources`; OntologyError naming a file that is unreadable or an entry
    whose kind is not a core class."""
    graph = rdflib.Graph()
    for source in sources:
        try:
            graph.parse(source, format="turtle")
        except (OSError, SyntaxError, ValueError) as e:
            raise OntologyError(f"cannot read the product catalogue {source}: {e}") from None
    products = []
    for node in graph.subjects(RDF.type, PRODUCTS.Product):
        kind = str(graph.value(node, PRODUCTS.kind) or "")
        if not kind.startswith(CORE_IRI):
            raise OntologyError(f"product {node} has no prod:kind in the core ontology (got {kind or 'none'!r})")
        fragments = tuple(sorted(str(f).lower() for f in graph.objects(node, PRODUCTS.nameFragment)))
        products.append(Product(str(graph.value(node, RDFS.label) or node), kind[len(CORE_IRI):],
                                fragments, str(graph.value(node, DCTERMS.source) or "")))
    return Catalogue(sorted(products, key=lambda p: p.label))


@functools.cache
def catalogue() -> Catalogue:
    """The packaged catalogue plus the files URDFKB_PRODUCTS names (read once per process)."""
    packaged = resources.files("urdfkb.ontologies").joinpath("products.ttl")
    extra = [p for p in os.environ.get(ENV, "").split(os.pathsep) if p]
    with resources.as_file(packaged) as path:
        return load([path, *extra])
