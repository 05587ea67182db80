"""Backends other than llama.cpp: the scripted test backend and the OpenAI-compatible HTTP client."""
import math

import pytest

from pipeline.llm.base import Question
from pipeline.llm.scripted import ScriptedBackend

OPTS = ("sensor", "gripper", "wheel")


def q(user="link: camera", options=OPTS):
    return Question(system="Classify the link.", user=user, options=options, key="kind:x")


def test_scripted_score_is_log_distribution():
    backend = ScriptedBackend(lambda _: {"sensor": 0.25, "wheel": 0.75})
    [row] = backend.score([q()])
    assert row[0] == pytest.approx(math.log(0.25))
    assert row[1] < -20
    assert row[2] == pytest.approx(math.log(0.75))
    assert ScriptedBackend(lambda _: "gripper").score([q()])[0][1] == 0.0
    assert backend.exposes_logits and backend.name == "scripted"


def test_scripted_sample_is_seeded_and_counts_calls():
    rule = lambda _: {"sensor": 0.5, "wheel": 0.5}  # noqa: E731
    a, b = ScriptedBackend(rule, seed=3), ScriptedBackend(rule, seed=3)
    assert a.sample(q(), 10, 0.7) == b.sample(q(), 10, 0.7)
    assert set(a.sample(q(), 50, 0.7)) == {"sensor", "wheel"}
    assert a.stats.calls == 60
