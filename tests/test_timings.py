"""The time breakdown: step records with their model work, stages around them, the --timings table."""
from __future__ import annotations

import io
import json

from tests.head_robot import HEAD, perfect
from urdfkb.kb_server.cli import main
from urdfkb.pipeline.reading.ingest import load_urdf
from urdfkb.pipeline.llm.scripted import ScriptedBackend
from urdfkb.pipeline.abstraction.passes import Pass, PassManager, Step
from urdfkb.pipeline.runner import Settings, run
from urdfkb.pipeline.timings import COUNTERS, Timings, process_age


def test_a_step_record_counts_the_work_done_in_it():
    records: list[dict] = []
    totals = {"tokens": 10}

    def work(context, state):
        totals["tokens"] += 5

    PassManager(records.append, lambda: dict(totals)).run(Pass("p", (Step("a", work),)), None, type("S", (), {"done": False})())
    assert records[0]["tokens"] == 5 and records[0]["step"] == "a"


def test_run_records_every_step_with_the_models_work_into_the_trace():
    out = io.StringIO()
    timings = Timings(out)
    backend = ScriptedBackend(perfect)
    run(load_urdf(HEAD.encode()), Settings(use_cache=False), backend=backend, trace=out, timings=timings)
    steps = [r for r in timings.records if "step" in r]
    assert steps and all(set(COUNTERS) <= set(r) for r in steps)
    assert sum(r["decodes"] for r in steps) == backend.stats.calls  # every backend call falls in some step
    identification = next(r for r in steps if r["step"] == "identification")
    assert identification["decodes"] > 0 and identification["model_seconds"] >= 0
    traced = [json.loads(line) for line in out.getvalue().splitlines()]
    assert [r for r in traced if r["key"] == "timing"] == timings.records


def test_the_table_adds_up_and_names_the_non_model_share():
    timings = Timings()
    timings.record({"stage": "startup", "seconds": 2.0})
    timings.record({"stage": "model load", "seconds": 3.0})
    timings.record({"pass": "sensor", "step": "identification", "seconds": 10.0, "model_seconds": 9.0, "tokens": 900,
                    "restored_tokens": 0, "decodes": 3, "reasoner_seconds": 0.0})
    timings.record({"pass": "body", "step": "body parts", "seconds": 4.0, "model_seconds": 1.0, "tokens": 100,
                    "restored_tokens": 0, "decodes": 1, "reasoner_seconds": 2.5})
    timings.record({"stage": "SHACL", "seconds": 1.0})
    timings.record({"stage": "total", "seconds": 20.0})
    table = timings.table()
    assert "sensor: identification" in table and "body pass" in table and "SHACL" in table
    assert timings.model_seconds() == 13.0
    assert "non-model share 35.0 %" in table and "reasoner 2.5 s" in table


def test_populate_prints_the_breakdown(tmp_path, capsys):
    trace = tmp_path / "trace.jsonl"
    assert main(["populate", "--structure-only", "--timings", "--trace", str(trace), "--format", "turtle",
                 "-o", str(tmp_path / "head.ttl"), _write(tmp_path)]) == 0
    out = capsys.readouterr().out
    for stage in ("ingest", "population", "SHACL", "export", "total", "non-model share"):
        assert stage in out
    stages = [json.loads(line).get("stage") for line in trace.read_text().splitlines()]
    assert stages == ["ingest", "population", "SHACL", "export", "total"]


def test_process_age_is_this_process_lifetime():
    assert 0 < process_age() < 24 * 3600


def _write(tmp_path) -> str:
    path = tmp_path / "head.urdf"
    path.write_text(HEAD)
    return str(path)
