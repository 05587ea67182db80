"""Oracle voting with the scripted backend: exact and sampled votes, ties, abstentions, failures, trace."""
import io
import json
import math

import pytest

from urdfkb.pipeline.errors import BackendError
from urdfkb.pipeline.llm.base import Question
from urdfkb.pipeline.llm.scripted import ScriptedBackend
from urdfkb.pipeline.abstraction.oracle import Oracle, Verdict, normalise

OPTS = ("sensor", "gripper", "wheel")


def q(user="link: camera", key="kind:camera", options=OPTS):
    return Question(system="Classify the link.", user=user, options=options, key=key)


def test_question_rejects_bad_options():
    for options in [(), ("a", ""), ("a", "a")]:
        with pytest.raises(ValueError):
            q(options=options)


def test_exact_is_renormalised_softmax():
    backend = ScriptedBackend(lambda _: {"sensor": 0.6, "gripper": 0.2, "wheel": 0.1, "other": 0.1})
    [v] = Oracle(backend).ask([q()])
    assert v.answer == "sensor"
    assert v.confidence == pytest.approx(0.6 / 0.9)
    assert v.distribution == pytest.approx({"sensor": 2 / 3, "gripper": 2 / 9, "wheel": 1 / 9})
    assert sum(v.distribution.values()) == pytest.approx(1.0)


def test_default_mode_follows_logits():
    backend = ScriptedBackend(lambda _: "wheel")
    assert Oracle(backend).vote == "exact"
    backend.exposes_logits = False
    assert Oracle(backend).vote == "sample"
    with pytest.raises(BackendError, match="log-probabilities"):
        Oracle(backend, vote="exact")
    with pytest.raises(ValueError):
        Oracle(backend, vote="majority")


def test_exact_tie_prefers_earlier_option():
    [v] = Oracle(ScriptedBackend(lambda _: {"gripper": 0.5, "wheel": 0.5})).ask([q()])
    assert v.answer == "gripper" and v.confidence == pytest.approx(0.5)


def test_sample_plurality_and_shares():
    backend = ScriptedBackend(lambda _: {"sensor": 0.7, "wheel": 0.3}, seed=1)
    [v] = Oracle(backend, vote="sample", votes=20).ask([q()])
    assert v.answer == "sensor"
    assert sum(v.distribution.values()) == pytest.approx(1.0)
    assert v.confidence == v.distribution["sensor"] > 0.5
    assert v.distribution["gripper"] == 0


def test_sample_tie_prefers_earlier_option():
    answers = iter(["wheel", "gripper", "wheel", "gripper"])
    [v] = Oracle(ScriptedBackend(lambda _: next(answers)), vote="sample", votes=4).ask([q()])
    assert v.answer == "gripper" and v.confidence == 0.5


def test_sample_normalises_case_and_space():
    assert normalise("  Sensor\n", OPTS) == "sensor"
    assert normalise("sensors", OPTS) is None
    assert normalise("A", ("a", "A")) == "A"
    assert normalise("b", ("A", "a")) is None
    assert normalise(None, OPTS) is None


def test_sample_retries_out_of_set_answers():
    answers = iter(["banana", "sensor", "sensor", "sensor"])
    backend = ScriptedBackend(lambda _: next(answers))
    [v] = Oracle(backend, vote="sample", votes=3, retries=2).ask([q()])
    assert v.answer == "sensor" and v.confidence == 1.0
    assert backend.stats.calls == 4


def test_sample_exhausted_retries_become_abstentions():
    answers = iter(["sensor", "x", "y", "z", "w"])
    [v] = Oracle(ScriptedBackend(lambda _: next(answers)), vote="sample", votes=2, retries=2).ask([q()])
    assert v.answer == "sensor" and v.confidence == 0.5
    assert sum(v.distribution.values()) == 0.5


def test_all_abstain():
    backend = ScriptedBackend(lambda _: "I think it is a sensor")
    [v] = Oracle(backend, vote="sample", votes=3, retries=1).ask([q()])
    assert v == Verdict(None, 0.0, {o: 0.0 for o in OPTS})
    assert backend.stats.calls == 6


@pytest.mark.parametrize("vote", ["exact", "sample"])
def test_backend_exception_becomes_backend_error(vote):
    def boom(_):
        raise RuntimeError("kaput")

    with pytest.raises(BackendError, match="scripted.*kaput"):
        Oracle(ScriptedBackend(boom), vote=vote).ask([q()])


def test_exact_garbage_scores_become_backend_error():
    class Garbage(ScriptedBackend):
        def score(self, questions):
            return [[math.nan, 0.0, 0.0]]

    with pytest.raises(BackendError, match="unusable"):
        Oracle(Garbage(lambda _: "x")).ask([q()])

    class Short(ScriptedBackend):
        def score(self, questions):
            return []

    with pytest.raises(BackendError, match="wrong number"):
        Oracle(Short(lambda _: "x")).ask([q()])


def test_sample_garbage_becomes_backend_error():
    class Garbage(ScriptedBackend):
        def sample(self, question, n, temperature):
            return "sensor"

    with pytest.raises(BackendError, match="not a list"):
        Oracle(Garbage(lambda _: "x"), vote="sample").ask([q()])


def test_trace_lines_and_provenance():
    trace = io.StringIO()
    oracle = Oracle(ScriptedBackend(lambda qq: "wheel" if "wheel" in qq.user else "sensor"), trace=trace)
    verdicts = oracle.ask([q("link: base_camera", "kind:cam"), q("link: left_wheel", "kind:wheel")])
    assert [v.answer for v in verdicts] == ["sensor", "wheel"]
    lines = [json.loads(line) for line in trace.getvalue().splitlines()]
    assert [line["key"] for line in lines] == ["kind:cam", "kind:wheel"]
    assert set(lines[0]) == {"key", "options", "distribution", "answer", "confidence", "mode"}
    assert lines[1]["answer"] == "wheel" and lines[1]["mode"] == "exact"
    assert lines[1]["options"] == list(OPTS)
    assert oracle.provenance() == {"model": "scripted", "vote": "exact"}  # votes and temperature play no part
    sampled = Oracle(ScriptedBackend(lambda qq: "sensor"), vote="sample", votes=3).provenance()
    assert sampled == {"model": "scripted", "vote": "sample", "votes": "3", "temperature": "0.7"}
    assert oracle.stats.calls == 2
    assert oracle.ask([]) == []
