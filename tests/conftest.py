"""Shared test fixtures: where the read-only shared assets live, and a store without query workers."""
from pathlib import Path

import pytest

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
