"""Settings, the result cache, and the runner's contract with its callers."""
from __future__ import annotations

import pytest

from urdfkb.pipeline import cache, runner
from urdfkb.pipeline.errors import BackendError
from urdfkb.pipeline.reading.ingest import load_urdf
from urdfkb.pipeline.llm.scripted import ScriptedBackend
from urdfkb.pipeline.runner import Settings
from tests.scripted_reasoner import scripted_reasoner
from tests.toy_robot import TOY, perfect


def run(tree, settings, **kw):
    """runner.run with the scripted reasoner: the toy's gripper needs no JVM."""
    return runner.run(tree, settings, reasoner=scripted_reasoner, **kw)


@pytest.fixture(autouse=True)
def private_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("URDFKB_CACHE", str(tmp_path / "cache"))


def test_settings_from_user_input_are_typed_and_checked():
    s = Settings.from_mapping({"vote": "sample", "votes": "7", "use_cache": "false"})
    assert (s.vote, s.votes, s.use_cache) == ("sample", 7, False)
    refused: list[tuple[dict[str, object], str]] = [({"colour": "red"}, "unknown setting"), ({"votes": "many"}, "integer"),
                         ({"vote": "shout"}, "exact"), ({"votes": 0}, "between"),
                         ({"structure_only": "maybe"}, "true or false"),
                         ({"model": "a.gguf", "llm_url": "http://127.0.0.1:1"}, "either")]
    for bad, message in refused:
        with pytest.raises(ValueError, match=message):
            Settings.from_mapping(bad)


def test_an_edited_product_catalogue_misses_the_cache(request):
    """The catalogue decides questions (a named product is shown and rules kinds out), so a user's products file,
    added or edited, misses results computed without it."""
    first = run(load_urdf(TOY), Settings(), backend=ScriptedBackend(perfect))
    assert "result_cache" not in first.provenance
    request.getfixturevalue("user_products")  # from here on, the user's file is part of the catalogue
    again = run(load_urdf(TOY), Settings(), backend=ScriptedBackend(perfect))
    assert "result_cache" not in again.provenance
    assert run(load_urdf(TOY), Settings(), backend=ScriptedBackend(perfect)).provenance["result_cache"] == "hit"


def test_structure_only_asks_nothing():
    backend = ScriptedBackend(perfect)
    result = run(load_urdf(TOY), Settings(structure_only=True), backend=backend)
    assert result.components == () and backend.stats.calls == 0


def test_an_identical_second_run_comes_from_the_cache():
    tree = load_urdf(TOY)
    first_backend = ScriptedBackend(perfect)
    first = run(tree, Settings(), backend=first_backend)
    assert first_backend.stats.calls > 0

    def must_not_be_called(q):
        raise AssertionError("the cache should have answered")
    second = run(load_urdf(TOY), Settings(), backend=ScriptedBackend(must_not_be_called))
    assert second.components == first.components
    # the counts are the computing run's; the stamp is this run's, and the hit is said
    assert second.provenance["llm_calls"] == first.provenance["llm_calls"] == str(first_backend.stats.calls)
    assert second.provenance["result_cache"] == "hit" and "result_cache" not in first.provenance
    assert second.provenance["generatedAt"] >= first.provenance["generatedAt"]


def test_other_settings_or_robots_miss_the_cache():
    tree = load_urdf(TOY)
    run(tree, Settings(), backend=ScriptedBackend(perfect))
    calls = ScriptedBackend(perfect)
    run(tree, Settings(vote="sample"), backend=calls)
    assert calls.stats.calls > 0
    other = load_urdf(TOY.read_bytes().replace(b"claw_tcp", b"claw_tool_point"))
    asked = ScriptedBackend(lambda q: q.options[0])  # `perfect` knows only the toy's own link names
    run(other, Settings(), backend=asked)
    assert asked.stats.calls > 0


def test_a_failing_backend_raises_and_caches_nothing(tmp_path):
    def broken(q):
        raise RuntimeError("out of memory")
    with pytest.raises(BackendError, match="out of memory"):
        run(load_urdf(TOY), Settings(), backend=ScriptedBackend(broken))
    assert not list((tmp_path / "cache").glob("**/*.json"))


@pytest.mark.slow  # over a second of its own (make test-fast leaves it out)
def test_a_corrupt_cache_entry_is_ignored(tmp_path):
    tree = load_urdf(TOY)
    first = run(tree, Settings(), backend=ScriptedBackend(perfect))
    (entry,) = (tmp_path / "cache" / "results").glob("*.json")
    entry.write_text("{not json")
    again = run(tree, Settings(), backend=ScriptedBackend(perfect))
    assert again.components == first.components  # recomputed (its wall time may differ)
    rewritten = cache.load(entry.stem)
    assert rewritten is not None and rewritten.components == again.components  # rewritten whole


def test_a_change_to_the_pipeline_code_misses_the_cache(monkeypatch):
    tree = load_urdf(TOY)
    run(tree, Settings(), backend=ScriptedBackend(perfect))
    monkeypatch.setattr(cache, "code_version", lambda: "an upgraded pipeline")
    again = ScriptedBackend(perfect)
    run(tree, Settings(), backend=again)
    assert again.stats.calls > 0


def test_a_single_link_robot_is_a_clear_error_not_a_crash():
    from urdfkb.pipeline.errors import URDFError
    tree = load_urdf(b'<robot name="lonely"><link name="only"/></robot>')
    with pytest.raises(URDFError, match="single link, 'only'"):
        run(tree, Settings(use_cache=False), backend=ScriptedBackend(lambda q: q.options[0]))
    assert run(tree, Settings(structure_only=True)).components == ()


def _robot_provenance(tree, abstraction) -> dict:
    """The Robot individual's provenance annotations, by local name, as rdflib terms (the robot conforms)."""
    import owlready2
    import rdflib
    from urdfkb.pipeline.knowledge.export import robot_graph
    from urdfkb.pipeline.knowledge.population import build_robot
    from urdfkb.pipeline.knowledge.shacl import validate
    g = robot_graph(build_robot(owlready2.World(), tree, "toy", abstraction))
    conforms, report = validate(g)
    assert conforms, report
    core = "https://w3id.org/urdfkb/core#"
    (robot,) = g.subjects(rdflib.RDF.type, rdflib.URIRef(core + "Robot"))
    return {str(p).removeprefix(core): o for p, o in g.predicate_objects(robot) if str(p).startswith(core)}


def test_a_populated_robot_says_when_from_what_with_which_software_and_model(tmp_path, monkeypatch):
    import hashlib
    from datetime import datetime, timedelta, timezone

    import rdflib

    import urdfkb
    gguf = tmp_path / "my-model.Q4.gguf"
    gguf.write_bytes(b"GGUF not really a model")
    monkeypatch.setattr(runner, "make_backend", lambda settings: ScriptedBackend(perfect, name="llama.cpp:my-model.Q4.gguf"))
    tree = load_urdf(TOY)
    before = datetime.now(timezone.utc).replace(microsecond=0)
    prov = _robot_provenance(tree, run(tree, Settings(model=str(gguf))))

    assert prov["urdfSha256"].toPython() == hashlib.sha256(TOY.read_bytes()).hexdigest()
    assert prov["softwareVersion"].toPython() == urdfkb.__version__
    assert prov["generatedAt"].datatype == rdflib.XSD.dateTime
    assert before <= prov["generatedAt"].toPython() <= datetime.now(timezone.utc) + timedelta(seconds=1)
    assert prov["modelFile"].toPython() == "my-model.Q4.gguf"
    assert prov["modelSha256"].toPython() == hashlib.sha256(gguf.read_bytes()).hexdigest()
    assert prov["abstractionModel"].toPython() == "llama.cpp:my-model.Q4.gguf"
    assert prov["votingMode"].toPython() == "exact"
    assert "votesPerQuestion" not in prov and "samplingTemperature" not in prov  # unused by exact voting

    sampled = _robot_provenance(tree, run(tree, Settings(model=str(gguf), vote="sample", votes=3)))
    assert (sampled["votingMode"].toPython(), sampled["votesPerQuestion"].toPython()) == ("sample", "3")

    gguf.write_bytes(b"GGUF another model at the same path")  # a replaced file misses the result cache
    again = run(tree, Settings(model=str(gguf)))
    assert "result_cache" not in again.provenance
    assert again.provenance["modelSha256"] == hashlib.sha256(gguf.read_bytes()).hexdigest()
    assert run(tree, Settings(model=str(gguf))).provenance["result_cache"] == "hit"


def test_the_default_model_is_named_by_its_verified_digest_without_hashing(monkeypatch):
    from urdfkb.pipeline.llm import fetch
    monkeypatch.setattr(runner, "make_backend", lambda settings: ScriptedBackend(perfect))
    monkeypatch.setattr(fetch, "_sha256", lambda path: pytest.fail("the fetched model is not hashed again"))
    prov = run(load_urdf(TOY), Settings()).provenance
    assert (prov["modelFile"], prov["modelSha256"]) == (fetch.DEFAULT_MODEL.filename, fetch.DEFAULT_MODEL.sha256)


def test_structure_only_and_http_runs_write_what_is_known(monkeypatch):
    tree = load_urdf(TOY)
    prov = _robot_provenance(tree, run(tree, Settings(structure_only=True)))
    assert prov["abstractionMode"].toPython() == "structure-only"
    assert {"generatedAt", "softwareVersion", "urdfSha256", "ontologyVersion"} <= prov.keys()
    assert not {"votingMode", "modelFile", "modelSha256", "abstractionModel"} & prov.keys()

    monkeypatch.setattr(runner, "make_backend", lambda settings: ScriptedBackend(perfect, name="openai:http://h/v1:m"))
    prov = _robot_provenance(tree, run(tree, Settings(llm_url="http://h/v1", llm_model="m", vote="sample")))
    assert prov["votingMode"].toPython() == "sample" and prov["abstractionModel"].toPython() == "openai:http://h/v1:m"
    assert not {"modelFile", "modelSha256"} & prov.keys()  # a server does not say which file it serves
