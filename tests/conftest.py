"""Shared test fixtures: where the read-only shared assets live, a store without query workers, and the
populated PR2 stores, built once per session (per pytest-xdist worker) and opened by each user as a copy."""
from pathlib import Path

import pytest

from tests.kb_fixtures import PR2, copied, store_whole_pr2
from tests.shared_assets import SHARED


@pytest.fixture(scope="session")
def shared() -> Path:
    if not SHARED.is_dir():
        pytest.skip(f"shared assets not found at {SHARED} (set URDFKB_SHARED)")
    return SHARED


@pytest.fixture
def store(tmp_path):
    """A new store answering SPARQL in this process (workers=0: no worker process to start). Tests of
    what the workers give (deadlines, crashes, readers never seeing a write half done) open their own."""
    from urdfkb.kb_server.store import Store

    s = Store(tmp_path / "kb.sqlite3", workers=0)
    yield s
    s.close()


@pytest.fixture(scope="session")
def pr2_tree(shared):
    """PR2's kinematic tree (shared/urdf/pr2.urdf); a KinematicTree is immutable."""
    from urdfkb.pipeline.reading.ingest import load_urdf

    return load_urdf(shared / "urdf" / "pr2.urdf")


def _built(folder: Path, fill) -> Path:
    """A closed store file in `folder`, filled by `fill(store)`."""
    from urdfkb.kb_server.store import Store

    s = Store(folder / "kb.sqlite3", workers=0)
    try:
        fill(s)
    finally:
        s.close()
    return s.path


@pytest.fixture(scope="session")
def pr2_kb(pr2_tree, tmp_path_factory) -> Path:
    """A store file holding "pr2" with its hand-written components (kb_fixtures.PR2). Never opened by a
    test: open a copy (kb_fixtures.copied), or take `pr2_store`."""
    return _built(tmp_path_factory.mktemp("pr2_kb"), lambda s: s.replace_robot("pr2", pr2_tree, PR2))


@pytest.fixture(scope="session")
def whole_pr2_kb(pr2_tree, tmp_path_factory) -> Path:
    """A store file holding PR2 with its whole body, the same with one gripper, and with no body
    (kb_fixtures.store_whole_pr2). Open a copy, as for pr2_kb."""
    return _built(tmp_path_factory.mktemp("whole_pr2_kb"), lambda s: store_whole_pr2(s, pr2_tree))


@pytest.fixture(scope="module")
def whole_pr2_store(whole_pr2_kb, tmp_path_factory):
    """A module's own store over a copy of whole_pr2_kb, with one query worker: for modules that only read it."""
    from urdfkb.kb_server.store import Store

    s = Store(copied(whole_pr2_kb, tmp_path_factory.mktemp("kb")), workers=1)
    yield s
    s.close()


@pytest.fixture
def pr2_store(pr2_kb, tmp_path):
    """This test's own store holding PR2 (a copy of pr2_kb), answering in this process: it may write."""
    from urdfkb.kb_server.store import Store

    s = Store(copied(pr2_kb, tmp_path), workers=0)
    yield s
    s.close()


@pytest.fixture
def user_products(tmp_path, monkeypatch):
    """A user's product catalogue file (one camera, "Acme EyeCam", fragment "eyecam") named by URDFKB_PRODUCTS for the
    test, the packaged catalogue's cache cleared before and after."""
    from urdfkb.pipeline.abstraction import catalogue as catalogue_mod
    own = tmp_path / "mine.ttl"
    own.write_text('@prefix prod: <https://w3id.org/urdfkb/products#> . @prefix core: <https://w3id.org/urdfkb/core#> .\n'
                   '@prefix rdfs: <http://www.w3.org/2000/01/rdf-schema#> . @prefix dcterms: <http://purl.org/dc/terms/> .\n'
                   'prod:Mine a prod:Product ; rdfs:label "Acme EyeCam" ; prod:kind core:MonocularCamera ;\n'
                   '    prod:nameFragment "eyecam" ; dcterms:source "Acme, EyeCam" .\n')
    monkeypatch.setenv(catalogue_mod.ENV, str(own))
    catalogue_mod.catalogue.cache_clear()
    yield own
    monkeypatch.delenv(catalogue_mod.ENV)
    catalogue_mod.catalogue.cache_clear()
