"""The one entry point from a parsed URDF to an Abstraction: settings, model backend, cache, passes."""
from __future__ import annotations

import dataclasses
import hashlib
import json
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Mapping, TextIO

from urdfkb.pipeline import cache
from urdfkb.pipeline.abstraction.abstractor import Abstractor
from urdfkb.pipeline.abstraction.catalogue import catalogue
from urdfkb.pipeline.abstraction.components import END_EFFECTOR, Abstraction
from urdfkb.pipeline.errors import BackendError, SettingsError, URDFError
from urdfkb.pipeline.llm.base import Backend
from urdfkb.pipeline.knowledge.ontology import vocabulary
from urdfkb.pipeline.abstraction.oracle import Oracle, check_voting
from urdfkb.pipeline.knowledge.population import stamp
from urdfkb.pipeline.knowledge.reasoning import Placer, Reasoner, classify_together, placements
from urdfkb.pipeline.knowledge.screen import hold_bodiless, hold_unsure, screen
from urdfkb.pipeline.abstraction.stages.asking import Progress
from urdfkb.pipeline.timings import Timings
from urdfkb.pipeline.reading.tree import KinematicTree
from urdfkb.settings import VOTES


@dataclass(frozen=True)
class Settings:
    """How to abstract a robot; every field is also a `populate` option and a POST /populate field."""

    structure_only: bool = False
    model: str | None = None       # GGUF path; None = the default model, fetched on first use
    llm_url: str | None = None     # an OpenAI-compatible server instead of the embedded model
    llm_model: str | None = None   # the model name that server should use
    vote: str | None = None        # "exact" or "sample"; None = exact when the backend has logits
    votes: int = VOTES
    use_cache: bool = True

    @classmethod
    def from_mapping(cls, data: Mapping[str, object]) -> "Settings":
        """Settings from user input (JSON or form fields); SettingsError naming anything invalid."""
        fields = {f.name: f for f in dataclasses.fields(cls)}
        unknown = set(data) - set(fields)
        if unknown:
            raise SettingsError(f"unknown setting(s): {', '.join(sorted(unknown))}; valid: {', '.join(fields)}")
        try:
            values: dict[str, Any] = {name: _coerce(name, str(fields[name].type), raw)  # annotations are strings here
                                      for name, raw in data.items()}
            settings = cls(**values)
            settings.check()
        except ValueError as e:
            raise SettingsError(str(e)) from None
        return settings

    def check(self) -> None:
        """ValueError naming the first invalid setting."""
        check_voting(self.vote, self.votes)
        if self.model and self.llm_url:
            raise ValueError("give either a model file or an LLM server URL, not both")


def _coerce(name: str, kind: str, raw: object) -> object:
    if "bool" in kind:
        if isinstance(raw, bool):
            return raw
        if str(raw).lower() in ("1", "true", "yes", "on"):
            return True
        if str(raw).lower() in ("0", "false", "no", "off"):
            return False
        raise ValueError(f"setting {name} must be true or false, not {raw!r}")
    if "int" in kind:
        try:
            return int(raw)  # type: ignore[call-overload]  # any object: TypeError is caught
        except (TypeError, ValueError):
            raise ValueError(f"setting {name} must be an integer, not {raw!r}") from None
    return None if raw in (None, "") else str(raw)


def make_backend(settings: Settings) -> Backend:
    """The backend the settings ask for: an HTTP server, a given GGUF, or the default model."""
    if settings.llm_url:
        from urdfkb.pipeline.llm.http import OpenAIBackend
        return OpenAIBackend(settings.llm_url, settings.llm_model or "default")
    from urdfkb.pipeline.llm.fetch import DEFAULT_MODEL, ensure_model
    from urdfkb.pipeline.llm.llama import LlamaBackend
    return LlamaBackend(settings.model or str(ensure_model(DEFAULT_MODEL)))


def _backend_id(settings: Settings, backend: Backend | None) -> str:
    if backend is not None:
        return backend.name
    if settings.llm_url:
        return f"openai:{settings.llm_url}:{settings.llm_model}"
    return f"gguf:{settings.model or 'default'}"


def _model_file(settings: Settings) -> dict[str, str]:
    """The GGUF file the embedded backend runs, by name and SHA-256 (nothing for an HTTP server, which
    does not say what file it serves). The default model's digest is the one verified when fetched;
    another file is hashed once per path, size and mtime (llm.fetch.model_sha256)."""
    if settings.llm_url:
        return {}
    from urdfkb.pipeline.llm.fetch import DEFAULT_MODEL, model_sha256
    if settings.model is None:
        return {"modelFile": DEFAULT_MODEL.filename, "modelSha256": DEFAULT_MODEL.sha256}
    try:
        return {"modelFile": Path(settings.model).name, "modelSha256": model_sha256(settings.model)}
    except OSError as e:
        raise BackendError(f"cannot read model file {settings.model}: {e.strerror}") from None


def tree_digest(tree: KinematicTree) -> str:
    """A digest of everything in the tree the pipeline reads (names, edges, joint types, origins, evidence)."""
    evidence = {link: dataclasses.asdict(facts) for link, facts in sorted(tree.evidence.items())}
    blob = json.dumps([tree.robot_name, tree.links, [dataclasses.asdict(e) for e in tree.edges], evidence])
    return hashlib.sha256(blob.encode()).hexdigest()


def _verification_log(trace: TextIO) -> Callable[[str], None]:
    """The verification step's notes, written to the trace as JSON lines."""
    def log(msg: str) -> None:
        trace.write(json.dumps({"key": "verification", "note": msg}) + "\n")
    return log


def _trace_writer(trace: TextIO) -> Callable[[dict], None]:
    """Records written to the trace as JSON lines."""
    def write(record: dict) -> None:
        trace.write(json.dumps(record) + "\n")
    return write


def run(tree: KinematicTree, settings: Settings, backend: Backend | None = None, progress: Progress | None = None,
        trace: TextIO | None = None, timings: Timings | None = None,
        backends: Callable[[Settings], Backend] | None = None, reasoner: Reasoner = classify_together,
        placer: Placer = placements) -> Abstraction:
    """Abstract a robot's sensors and end-effectors (nothing when structure_only).

    `backend` overrides the one the settings name (tests inject a scripted one); `backends` gives the
    one the settings name when it is needed (the server's warm model), kept open after the run. Results are
    cached by URDF digest, model (its file's digest too), vocabulary (ontology and shapes) and settings;
    the backend is closed after use. The provenance always carries population.stamp(tree) for this
    run; when the result cache answers, the counts and seconds are those of the run that computed it,
    and result_cache=hit. `timings` receives the model load's and every step's timing records (else
    the steps' go to the trace). `reasoner` and `placer` stand in for HermiT (tests inject ones that agree
    with it: they are no part of the cache key). Sensors under the confidence floor, and components and body parts
    that break the SHACL shapes, are held back for review (pipeline.knowledge.screen), each recorded in the trace.
    """
    if settings.structure_only:
        return Abstraction((), {"mode": "structure-only", **stamp(tree)})
    if len(tree.links) == 1:
        raise URDFError(f"robot {tree.robot_name!r} has a single link, {tree.root!r}: no device to abstract "
                        "(--structure-only writes its structure)", f"link '{tree.root}'")
    settings_key = {k: v for k, v in dataclasses.asdict(settings).items() if k != "use_cache"}
    model_file = _model_file(settings) if backend is None else {}  # its digest keys the cache: a replaced file misses
    digest = cache.key(tree_digest(tree), [_backend_id(settings, backend), model_file],
                       f"{vocabulary().fingerprint}/{catalogue().fingerprint}", settings_key)
    if settings.use_cache and (hit := cache.load(digest)) is not None:
        return hit.with_provenance({"result_cache": "hit", **stamp(tree)})
    owned = backend is None and backends is None
    if backend is None:
        loading = time.perf_counter()
        backend = (backends or make_backend)(settings)
        if timings is not None:
            timings.record({"stage": "model load", "seconds": round(time.perf_counter() - loading, 4)})
    try:
        oracle = Oracle(backend, vote=settings.vote, votes=settings.votes, trace=trace)
        started = time.monotonic()
        log = _verification_log(trace) if trace else None
        abstractor = Abstractor(oracle, vocabulary(), progress, log, timings.record if timings else None, reasoner, placer)
        found = abstractor.run(tree)
        components, body = found.components, found.body
        stats = oracle.stats
        provenance = {
            **oracle.provenance(),
            **model_file,
            "declared_constraints": str(abstractor.tally.declared),
            "llm_calls": str(stats.calls),
            "prompt_tokens": str(stats.prompt_tokens),
            "seconds": f"{time.monotonic() - started:.1f}",
        }
    finally:
        if owned:
            backend.close()
    record = _trace_writer(trace) if trace else None
    kept = hold_unsure(tree, Abstraction(tuple(components), provenance, tuple(body)), record)
    kept = hold_bodiless(tree, kept, vocabulary().kinds[END_EFFECTOR].cls, record)
    result = screen(tree, kept, record)
    if settings.use_cache:
        cache.store(digest, result)
    return result.with_provenance(stamp(tree))
