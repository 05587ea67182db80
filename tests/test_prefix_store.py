"""The on-disk store of prompt-prefix KV states: keys, integrity, atomic writes, size bound."""
import logging
import os

import pytest

from urdfkb.pipeline.llm import prefix_store
from urdfkb.pipeline.llm.prefix_store import PrefixStore

IDENTITY = {"model": ["/models/m.gguf", 1000, 1], "context": {"n_ctx": 4096}}
TOKENS = [1, 2, 3, 4, 5]


def loaded(store: PrefixStore, tokens: list[int]) -> bytes:
    """The payload `store` holds for `tokens` (it must hold one)."""
    payload = store.load(tokens)
    assert payload is not None
    return bytes(payload)


def test_round_trip(tmp_path):
    store = PrefixStore(tmp_path, IDENTITY)
    assert store.load(TOKENS) is None
    store.save(TOKENS, b"state bytes")
    assert loaded(store, TOKENS) == b"state bytes"
    assert store.hits == 1 and store.writes == 1
    assert [p.name for p in tmp_path.iterdir()] == [store.path(TOKENS).name]  # no temporary file left


def test_key_covers_tokens_and_identity(tmp_path):
    store = PrefixStore(tmp_path, IDENTITY)
    store.save(TOKENS, b"x")
    store.save(TOKENS[:3], b"head")
    assert loaded(store, TOKENS[:3]) == b"head" and loaded(store, TOKENS) == b"x"
    assert store.load(TOKENS[:-1]) is None and store.load(TOKENS + [6]) is None
    other_model = PrefixStore(tmp_path, {**IDENTITY, "model": ["/models/m.gguf", 1000, 2]})
    assert other_model.load(TOKENS) is None
    assert PrefixStore(tmp_path, dict(reversed(IDENTITY.items()))).load(TOKENS) is not None  # order-free


@pytest.mark.parametrize("damage", ["flip", "truncate", "empty", "magic"])
def test_corrupt_file_is_ignored_logged_and_removed(tmp_path, caplog, damage):
    store = PrefixStore(tmp_path, IDENTITY)
    store.save(TOKENS, b"0123456789" * 10)
    path = store.path(TOKENS)
    blob = bytearray(path.read_bytes())
    if damage == "flip":
        blob[-3] ^= 0xFF
    elif damage == "truncate":
        blob = blob[:-7]
    elif damage == "empty":
        blob = bytearray()
    else:
        blob[:4] = b"GGUF"
    path.write_bytes(bytes(blob))
    with caplog.at_level(logging.WARNING, logger=prefix_store.__name__):
        assert store.load(TOKENS) is None
    assert "ignoring cached prompt state" in caplog.text and str(path) in caplog.text
    assert not path.exists() and store.rejected == 1


def test_file_under_another_key_is_rejected(tmp_path, caplog):
    """A file copied or renamed onto another prefix's name is caught by the key in its header."""
    store = PrefixStore(tmp_path, IDENTITY)
    store.save(TOKENS, b"state of TOKENS")
    os.replace(store.path(TOKENS), store.path(TOKENS[:2]))
    with caplog.at_level(logging.WARNING, logger=prefix_store.__name__):
        assert store.load(TOKENS[:2]) is None
    assert "another format or key" in caplog.text


def test_size_bound_evicts_least_recently_used(tmp_path):
    for i in range(3):
        PrefixStore(tmp_path, IDENTITY).save([i], bytes(1000))
    store = PrefixStore(tmp_path, IDENTITY, max_bytes=2500)
    for i in range(3):
        os.utime(store.path([i]), ns=(i * 10**9, i * 10**9))  # distinct ages: 0 oldest
    assert store.load([0]) is not None  # a hit makes 0 the most recently used
    store.save([3], bytes(1000))
    assert [store.path([i]).exists() for i in range(4)] == [True, False, False, True]
    assert sum(p.stat().st_size for p in tmp_path.iterdir()) <= 2500


def test_entry_larger_than_the_bound_is_still_kept(tmp_path):
    store = PrefixStore(tmp_path, IDENTITY, max_bytes=10)
    store.save(TOKENS, bytes(100))
    assert store.load(TOKENS) is not None


def test_stale_temporary_files_are_swept(tmp_path):
    stale, fresh = tmp_path / ".abc.tmp", tmp_path / ".def.tmp"
    stale.write_bytes(b"half")
    fresh.write_bytes(b"half")
    os.utime(stale, (0, 0))
    PrefixStore(tmp_path, IDENTITY).save(TOKENS, b"x")
    assert not stale.exists() and fresh.exists()  # a writer may still own the fresh one


def test_unwritable_directory_only_logs(tmp_path, caplog):
    blocker = tmp_path / "file"
    blocker.write_text("not a directory")
    store = PrefixStore(blocker / "sub", IDENTITY)
    with caplog.at_level(logging.WARNING, logger=prefix_store.__name__):
        store.save(TOKENS, b"x")
    assert "cannot write cached prompt state" in caplog.text and store.writes == 0
    assert store.load(TOKENS) is None


def test_default_dir_and_switch(monkeypatch, tmp_path):
    monkeypatch.setenv("URDFKB_CACHE", str(tmp_path))
    assert prefix_store.default_dir() == tmp_path / "prefixes"
    for off in ("off", "0", "false", "NO"):
        monkeypatch.setenv(prefix_store.ENV_SWITCH, off)
        assert not prefix_store.enabled_by_env()
    monkeypatch.setenv(prefix_store.ENV_SWITCH, "on")
    assert prefix_store.enabled_by_env()
    monkeypatch.delenv(prefix_store.ENV_SWITCH)
    assert prefix_store.enabled_by_env()  # on unless switched off
