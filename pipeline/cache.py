"""A result cache: an identical run (same robot, model, ontology, settings and code) is answered from disk."""
from __future__ import annotations

import functools
import hashlib
import json
import os
from pathlib import Path

import platformdirs

from urdfkb.pipeline.atomic import write_atomically
from urdfkb.pipeline.abstraction.components import Abstraction


@functools.cache
def code_version() -> str:
    """A digest of the pipeline's own source: any change to prompts or stages misses old entries."""
    digest = hashlib.sha256()
    for path in sorted(Path(__file__).parent.rglob("*.py")):
        digest.update(path.read_bytes())
    return digest.hexdigest()[:16]


def cache_root() -> Path:
    """The root of everything urdfkb caches (results, models, prompt states): $URDFKB_CACHE, else the
    user cache directory."""
    return Path(os.environ.get("URDFKB_CACHE") or platformdirs.user_cache_dir("urdfkb"))


def results_dir() -> Path:
    """Where results are kept: $URDFKB_RESULT_CACHE, else cache_root()/results (so the result cache
    can be moved or emptied without touching the models)."""
    return Path(os.environ.get("URDFKB_RESULT_CACHE") or cache_root() / "results")


def key(tree_digest: str, model: object, ontology: str, settings: dict) -> str:
    """A digest of everything that determines the result: the robot, the model (any JSON value), the ontology,
    the settings and the pipeline code."""
    blob = json.dumps([code_version(), tree_digest, model, ontology, settings], sort_keys=True)
    return hashlib.sha256(blob.encode()).hexdigest()


def load(digest: str) -> Abstraction | None:
    """The cached result, or None when absent or unreadable."""
    path = results_dir() / f"{digest}.json"
    try:
        return Abstraction.from_dict(json.loads(path.read_text()))
    except (OSError, ValueError, KeyError, TypeError):
        return None


def store(digest: str, abstraction: Abstraction) -> None:
    """Write atomically, so a crash never leaves a half-written entry."""
    folder = results_dir()
    folder.mkdir(parents=True, exist_ok=True)
    write_atomically(folder / f"{digest}.json", json.dumps(abstraction.to_dict()).encode())
