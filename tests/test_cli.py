"""The urdfkb command end to end (model-free paths; the model path is in test_llama_integration)."""
from __future__ import annotations

import importlib.metadata
import subprocess
import sys
import zipfile
from pathlib import Path

import owlready2
import pytest
import rdflib

from urdfkb.kb_server.cli import main
from urdfkb.pipeline.abstraction.components import Abstraction, Held

REPO = Path(__file__).resolve().parents[1]
TOY = REPO / "tests" / "data" / "toy_robot.urdf"
CORE = "https://w3id.org/urdfkb/core#"


@pytest.mark.parametrize("fmt,suffix,rdf_format", [("rdfxml", ".owl", "xml"), ("turtle", ".ttl", "turtle"), ("ntriples", ".nt", "nt")])
@pytest.mark.slow  # over a second of its own (make test-fast leaves it out)
def test_populate_structure_only_writes_a_self_contained_file(tmp_path, shared, capsys, fmt, suffix, rdf_format):
    out = tmp_path / f"pr2{suffix}"
    assert main(["populate", str(shared / "urdf" / "pr2.urdf"), "--structure-only", "--format", fmt, "-o", str(out)]) == 0
    assert str(out) in capsys.readouterr().out
    graph = rdflib.Graph().parse(out, format=rdf_format)
    links = set(graph.subjects(rdflib.RDF.type, rdflib.URIRef(CORE + "Link")))
    assert len(links) == 95
    assert not list(graph.objects(None, rdflib.OWL.imports))


def test_populated_file_reloads_in_owlready2(tmp_path):
    out = tmp_path / "toy.owl"
    assert main(["populate", str(TOY), "--structure-only", "-o", str(out)]) == 0
    world = owlready2.World()
    onto = world.get_ontology(out.as_uri()).load()
    assert onto.search_one(urdfName="claw_tcp") is not None


def test_a_bad_urdf_is_a_clear_error_and_writes_nothing(tmp_path, capsys):
    bad = tmp_path / "bad.urdf"
    bad.write_text('<robot name="r"><link name="a"/><joint name="j" type="fixed"><parent link="a"/><child link="ghost"/></joint></robot>')
    out = tmp_path / "bad.owl"
    assert main(["populate", str(bad), "--structure-only", "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("urdfkb: error:") and "ghost" in err
    assert not out.exists()


def test_max_links_and_max_bytes_limit_populate(tmp_path, capsys):
    out = tmp_path / "toy.owl"
    assert main(["populate", str(TOY), "--structure-only", "--max-links", "16", "-o", str(out)]) == 2
    assert "too many links: 17, over the limit of 16" in capsys.readouterr().err
    assert main(["populate", str(TOY), "--structure-only", "--max-bytes", "100", "-o", str(out)]) == 2
    assert "over the 100-byte limit" in capsys.readouterr().err
    assert not out.exists()
    assert main(["populate", str(TOY), "--structure-only", "--max-links", "17", "-o", str(out)]) == 0


def test_an_existing_output_survives_a_failed_populate(tmp_path):
    out = tmp_path / "robot.owl"
    out.write_text("earlier result")
    missing = tmp_path / "missing.urdf"
    assert main(["populate", str(missing), "--structure-only", "-o", str(out)]) == 2
    assert out.read_text() == "earlier result"


def test_populate_names_what_the_shapes_held_back(tmp_path, capsys, monkeypatch):
    held = Held("mast_cam", "sensor", "MonocularCamera", ("claw_status_light",), ("CameraShape: comp_mast_cam: why",))
    monkeypatch.setattr("urdfkb.pipeline.runner.run", lambda *_args, **_kw: Abstraction(held=(held,)))
    assert main(["populate", str(TOY), "-o", str(tmp_path / "toy.owl")]) == 0
    out = capsys.readouterr().out
    assert "held back for review, not written: MonocularCamera mast_cam on claw_status_light" in out
    assert "    CameraShape: comp_mast_cam: why" in out


@pytest.mark.slow  # over a second of its own (make test-fast leaves it out)
def test_validate_reports_conformance_and_violations(tmp_path, capsys):
    good = tmp_path / "toy.ttl"
    main(["populate", str(TOY), "--structure-only", "--format", "turtle", "-o", str(good)])
    assert main(["validate", str(good)]) == 0
    graph = rdflib.Graph().parse(good)
    link = next(graph.subjects(rdflib.RDF.type, rdflib.URIRef(CORE + "Link")))
    graph.add((link, rdflib.URIRef(CORE + "urdfName"), rdflib.Literal("a second name")))
    bad = tmp_path / "bad.ttl"
    graph.serialize(bad, format="turtle")
    capsys.readouterr()
    assert main(["validate", str(bad)]) == 1
    assert "urdfName" in capsys.readouterr().out


def test_validate_refuses_a_non_rdf_file(tmp_path, capsys):
    junk = tmp_path / "junk.ttl"
    junk.write_text("this is not RDF {")
    assert main(["validate", str(junk)]) == 2
    assert "cannot read" in capsys.readouterr().err


def test_console_script_help_lists_every_command():
    out = subprocess.run([sys.executable, "-m", "urdfkb", "--help"], capture_output=True, text=True, check=True).stdout
    for command in ("populate", "validate", "eval", "model", "serve", "query"):
        assert command in out
    sub = subprocess.run([sys.executable, "-m", "urdfkb", "populate", "--help"], capture_output=True, text=True, check=True).stdout
    for option in ("--structure-only", "--format", "--trace", "--vote", "--votes", "--model", "--llm-url", "--quiet"):
        assert option in sub



def test_query_offers_every_results_format_the_server_answers_in():
    from urdfkb.kb_server.cli import build_parser
    from urdfkb.pipeline.knowledge.formats import RESULTS_FORMATS
    for fmt in ("table", *(f.name for f in RESULTS_FORMATS)):
        assert build_parser().parse_args(["query", "cameras", "--robot", "pr2", "--format", fmt]).format == fmt

def test_a_failing_model_backend_is_a_clear_error_and_writes_nothing(tmp_path, capsys, monkeypatch):
    import socket
    monkeypatch.setenv("URDFKB_CACHE", str(tmp_path / "cache"))
    with socket.socket() as s:  # a port nobody listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    out = tmp_path / "toy.owl"
    out.write_text("earlier result")
    code = main(["populate", str(TOY), "-o", str(out), "--llm-url", f"http://127.0.0.1:{port}/v1", "--llm-model", "m", "--quiet"])
    assert code == 2
    err = capsys.readouterr().err
    assert err.startswith("urdfkb: error:") and f"127.0.0.1:{port}" in err
    assert out.read_text() == "earlier result"


def test_version_is_the_package_version():
    import urdfkb
    out = subprocess.run([sys.executable, "-m", "urdfkb", "--version"], capture_output=True, text=True, check=True).stdout
    assert out.strip() == f"urdfkb {urdfkb.__version__}"
    assert importlib.metadata.version("urdfkb") == urdfkb.__version__


@pytest.mark.slow
def test_the_wheel_installs_one_top_level_package(tmp_path):
    """`pip install .` must put only `urdfkb` into site-packages, with the data files it reads."""
    subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(tmp_path), str(REPO)],
                   check=True, capture_output=True)
    (wheel,) = tmp_path.glob("urdfkb-*.whl")
    names = zipfile.ZipFile(wheel).namelist()
    top = {name.split("/")[0] for name in names if not name.split("/")[0].endswith(".dist-info")}
    assert top == {"urdfkb"}
    for needed in ("urdfkb/ontologies/urdfkb.owl", "urdfkb/ontologies/shapes.ttl", "urdfkb/queries/cameras.rq",
                   "urdfkb/kb_server/samples/turtlebot3_waffle_pi.urdf", "urdfkb/kb_server/templates/robot.html",
                   "urdfkb/pipeline/abstraction/stages/identification.py", "urdfkb/__main__.py"):
        assert needed in names


def test_a_robot_whose_root_is_its_only_leaf_is_a_clear_error(tmp_path, capsys):
    lonely = tmp_path / "lonely.urdf"
    lonely.write_text('<robot name="lonely"><link name="only"/></robot>')
    out = tmp_path / "lonely.owl"
    assert main(["populate", str(lonely), "-o", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("urdfkb: error: robot 'lonely' has a single link, 'only': no device to abstract")
    assert "--structure-only" in err and "Traceback" not in err and not out.exists()
    assert main(["populate", str(lonely), "-o", str(out), "--structure-only", "--quiet"]) == 0 and out.exists()
