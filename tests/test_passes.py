"""The pass manager: declared steps run in order, each timed into the trace, a pass ends when a step is done."""
import io
import json
from dataclasses import dataclass, field

import pytest

from tests.scripted_reasoner import scripted_reasoner
from tests.toy_robot import TOY, perfect
from urdfkb.pipeline.abstraction.abstractor import GIVEN, PASSES, Abstractor
from urdfkb.pipeline.errors import OntologyError
from urdfkb.pipeline.reading.ingest import load_urdf
from urdfkb.pipeline.llm.scripted import ScriptedBackend
from urdfkb.pipeline.knowledge.ontology import vocabulary
from urdfkb.pipeline.abstraction.oracle import Oracle
from urdfkb.pipeline.abstraction.passes import Pass, PassManager, Step, check_order, step
from urdfkb.pipeline.abstraction.steps.findings import LASTING


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


def test_every_component_kind_has_a_declared_pass_sensors_first():
    assert [p.name for p in PASSES] == ["sensor", "end_effector", "body"]
    with pytest.raises(OntologyError, match="no pass declared for component kind.*end_effector"):
        Abstractor(Oracle(ScriptedBackend(perfect)), vocabulary(), passes=PASSES[:1])


def test_a_step_declaring_a_field_the_findings_record_lacks_is_refused_where_it_is_declared():
    with pytest.raises(ValueError, match="step 'x' declares hands, chain: no such field of the findings record"):
        @step("x", needs=("leaves", "hands"), makes=("chain",))
        def x(context, found):
            pass


def test_an_error_inside_a_step_names_its_pass_and_step():
    def broken(context, state):
        raise KeyError("left_finger")

    with pytest.raises(KeyError) as raised:
        PassManager(lambda _record: None).run(Pass("p", (Step("a", lambda c, s: None), Step("b", broken))), None, Ran())
    assert raised.value.__notes__ == ["in pass 'p', step 'b'"]


def test_the_trace_times_every_step_of_every_pass():
    out = io.StringIO()
    Abstractor(Oracle(ScriptedBackend(perfect), trace=out), vocabulary(), reasoner=scripted_reasoner).run(load_urdf(TOY))
    timed = [(r["pass"], r["step"]) for r in map(json.loads, out.getvalue().splitlines()) if r["key"] == "timing"]
    assert timed == [(p.name, s.name) for p in PASSES for s in p.steps]


@pytest.mark.reasoner
def test_one_reasoner_run_settles_the_tools_and_the_body_candidates():
    """The end-effector pass's HermiT run also classifies the body pass's candidates (the toy's gripper is
    settled by its structure), and the body pass takes those classes: the same as a run of its own."""
    from urdfkb.pipeline.knowledge import reasoning
    from urdfkb.pipeline.abstraction.stages import body

    runs = []

    def counted(tools, parts):
        runs.append((len(tools), len(parts)))
        return reasoning.classify_together(tools, parts)

    robot = load_urdf(TOY)
    abstractor = Abstractor(Oracle(ScriptedBackend(perfect)), vocabulary(), reasoner=counted)
    found = abstractor.run(robot)
    components = body.with_joints(robot, found.components)
    assert found.body_reasoned is not None
    facts, classes = found.body_reasoned
    assert runs == [(1, len(facts))]
    assert facts == body.findings(robot, body.candidates(robot, components), components).facts
    assert any(classes)
    assert reasoning.classify_parts(facts)[0] == classes


def test_a_step_before_what_it_reads_is_refused_when_the_passes_are_declared():
    """check_order, run on PASSES at import: moving the shape step after identification (or the end-effector
    pass before the sensor pass that makes what shape settles) is an error naming the step and what it lacks;
    a field of one pass's own is not there for the next."""
    check_order(PASSES, given=GIVEN, lasting=LASTING)
    sensor = PASSES[0]
    swapped = Pass(sensor.name, (sensor.steps[1], sensor.steps[0], *sensor.steps[2:]))
    with pytest.raises(ValueError, match="step 'identification' needs hand_mounts, feet"):
        check_order((swapped, *PASSES[1:]), given=GIVEN, lasting=LASTING)
    with pytest.raises(ValueError, match="pass 'end_effector', step 'identification' needs hand_mounts"):
        check_order((PASSES[1], PASSES[0], PASSES[2]), given=GIVEN, lasting=LASTING)
    with pytest.raises(ValueError, match="needs b"):
        check_order((Pass("p", (Step("x", print, needs=("b",)), Step("y", print, makes=("b",)))),), given=())
    made, used = Pass("p", (Step("x", print, makes=("b", "c")),)), Pass("q", (Step("y", print, needs=("c", "b")),))
    with pytest.raises(ValueError, match="pass 'q', step 'y' needs b"):
        check_order((made, used), given=(), lasting=frozenset({"c"}))
