"""`urdfkb populate` end to end on the real embedded llama.cpp backend with the small SmolLM2 model.

SmolLM2-135M is too small to classify well; this checks the machinery with a real model: every
answer is one of its question's options, the result passes the SHACL gate, and the file is whole.
"""
import json
from pathlib import Path

import pytest
import rdflib

from urdfkb.kb_server.cli import main
from urdfkb.pipeline.llm.fetch import TEST_MODEL, ensure_model
from urdfkb.pipeline.knowledge.ontology import vocabulary

pytestmark = pytest.mark.model
TOY = Path(__file__).parent / "data" / "toy_robot.urdf"
CORE = "https://w3id.org/urdfkb/core#"


def test_populate_with_the_embedded_model(tmp_path, monkeypatch):
    monkeypatch.setenv("URDFKB_RESULT_CACHE", str(tmp_path / "results"))  # the fetched model stays shared
    model = ensure_model(TEST_MODEL, progress=False)
    out, trace = tmp_path / "toy.ttl", tmp_path / "trace.jsonl"
    argv = ["populate", str(TOY), "--model", str(model), "--format", "turtle", "-o", str(out), "--trace", str(trace), "--quiet"]
    assert main(argv) == 0

    records = [json.loads(line) for line in trace.read_text().splitlines()]
    questions = [r for r in records if "options" in r]
    assert len(questions) >= 9  # at least one identification question per leaf
    assert all(r["answer"] is None or r["answer"] in r["options"] for r in questions)
    assert all(abs(sum(r["distribution"].values()) - 1) < 1e-6 for r in questions)

    graph = rdflib.Graph().parse(out, format="turtle")
    tax = vocabulary()
    robot = next(graph.subjects(rdflib.RDF.type, rdflib.URIRef(CORE + "Robot")))
    # the gripper's fingers are claimed by structure, whatever the model says: at least it is found
    components = list(graph.objects(robot, rdflib.URIRef(CORE + "hasComponent")))
    classes = {comp: {str(c).removeprefix(CORE) for c in graph.objects(comp, rdflib.RDF.type)} & set(tax._order)
               for comp in components}
    assert components and all(classes.values()), classes
    assert any(tax.is_a(c, "EndEffector") for found in classes.values() for c in found), classes
    model_note = graph.value(robot, rdflib.URIRef(CORE + "abstractionModel"))
    assert model_note is not None and "SmolLM2" in str(model_note)

    # an identical second run is answered from the cache: no question, no pass, only the stages' timings
    assert main(argv) == 0
    again = [json.loads(line) for line in trace.read_text().splitlines()]
    assert {r["key"] for r in again} == {"timing"} and not any("step" in r or "model" in r.get("stage", "") for r in again)
