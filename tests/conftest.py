"""Shared test fixtures: where the read-only shared assets live."""
import os
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
SHARED = Path(os.environ.get("URDFKB_SHARED", REPO.parent / "shared")).resolve()


@pytest.fixture(scope="session")
def shared() -> Path:
    if not SHARED.is_dir():
        pytest.fail(f"shared assets not found at {SHARED} (set URDFKB_SHARED)")
    return SHARED
