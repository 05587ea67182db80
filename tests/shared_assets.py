"""Where the read-only shared assets live: ../shared beside the repository, or $URDFKB_SHARED. Modules that
parametrise over its files at collection read SHARED; tests take conftest's `shared` fixture, which skips
where the assets are missing."""
import os
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
SHARED = Path(os.environ.get("URDFKB_SHARED", REPO.parent / "shared")).resolve()
