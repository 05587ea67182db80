"""The pass manager: declared steps run in order, each timed into the trace, a pass ends when a step is done."""
import io
import json
from dataclasses import dataclass, field

import pytest

from tests.scripted_reasoner import scripted_reasoner
from tests.toy_robot import TOY, perfect
from urdfkb.pipeline import abstraction
from urdfkb.pipeline.abstraction import PASSES, Abstractor
from urdfkb.pipeline.errors import OntologyError
from urdfkb.pipeline.ingest import load_urdf
from urdfkb.pipeline.llm.scripted import ScriptedBackend
from urdfkb.pipeline.ontology import vocabulary
from urdfkb.pipeline.oracle import Oracle
from urdfkb.pipeline.passes import Pass, PassManager, Step, check_order


@dataclass
class Ran:
    ran: list[str] = field(default_factory=list)
    done: bool = False


def test_steps_run_in_order_each_timed_until_one_is_done():
    records: list[dict] = []

    def note(name, finish=False):
        def run(context, state):
            state.ran.append(f"{context}:{name}")
            state.done = finish
        return run

    state = Ran()
    declared = Pass("p", (Step("a", note("a")), Step("b", note("b", finish=True)), Step("c", note("c"))))
    PassManager(records.append).run(declared, "ctx", state)
    assert state.ran == ["ctx:a", "ctx:b"]
    assert [(r["key"], r["pass"], r["step"]) for r in records] == [("timing", "p", "a"), ("timing", "p", "b")]
    assert all(isinstance(r["seconds"], float) and r["seconds"] >= 0 for r in records)


def test_a_pass_names_each_step_once():
    with pytest.raises(ValueError, match="twice"):
        Pass("p", (Step("a", print), Step("a", print)))


def test_every_component_kind_has_a_declared_pass_sensors_first(monkeypatch):
    assert [p.name for p in PASSES] == ["sensor", "end_effector", "body"]
    monkeypatch.setattr(abstraction, "PASSES", PASSES[:1])
    with pytest.raises(OntologyError, match="no pass declared for component kind.*end_effector"):
        Abstractor(Oracle(ScriptedBackend(perfect)), vocabulary())


def test_the_trace_times_every_step_of_every_pass():
    out = io.StringIO()
    Abstractor(Oracle(ScriptedBackend(perfect), trace=out), vocabulary(), reasoner=scripted_reasoner).run(load_urdf(TOY))
    timed = [(r["pass"], r["step"]) for r in map(json.loads, out.getvalue().splitlines()) if r["key"] == "timing"]
    assert timed == [(p.name, s.name) for p in PASSES for s in p.steps]


@pytest.mark.reasoner
def test_one_reasoner_run_settles_the_tools_and_the_body_candidates():
    """The end-effector pass's HermiT run also classifies the body pass's candidates (the toy's gripper is
    settled by its structure), and the body pass takes those classes: the same as a run of its own."""
    from urdfkb.pipeline import reasoning
    from urdfkb.pipeline.stages import body

    runs = []

    def counted(tools, parts):
        runs.append((len(tools), len(parts)))
        return reasoning.classify_together(tools, parts)

    robot = load_urdf(TOY)
    abstractor = Abstractor(Oracle(ScriptedBackend(perfect)), vocabulary(), reasoner=counted)
    components = body.with_joints(robot, list(abstractor.run(robot)))
    assert abstractor.body_reasoned is not None
    facts, classes = abstractor.body_reasoned
    assert runs == [(1, len(facts))]
    assert facts == body.findings(robot, body.candidates(robot, components), components).facts
    assert any(classes)
    assert reasoning.classify_parts(facts)[0] == classes


def test_a_step_before_what_it_reads_is_refused_when_the_passes_are_declared():
    """check_order, run on PASSES at import: moving the finger structure after identification (or the end-effector
    pass before the sensor pass that makes it) is an error naming the step and what it lacks."""
    check_order(PASSES, given=("robot", "tree", "components"))
    sensor = PASSES[0]
    swapped = Pass(sensor.name, (sensor.steps[1], sensor.steps[0], *sensor.steps[2:]))
    with pytest.raises(ValueError, match="step 'identification' needs hands, feet"):
        check_order((swapped, *PASSES[1:]), given=("robot", "tree", "components"))
    with pytest.raises(ValueError, match="pass 'end_effector', step 'identification' needs hands"):
        check_order((PASSES[1], PASSES[0], PASSES[2]), given=("robot", "tree", "components"))
    with pytest.raises(ValueError, match="needs b"):
        check_order((Pass("p", (Step("x", print, needs=("b",)), Step("y", print, makes=("b",)))),), given=())
