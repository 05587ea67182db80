"""The property-restriction loop (pipeline.abstraction.steps.body.placement): a generated robot whose model takes a chest button, and
a pad of two frames, on a lifting torso for bumpers (a bumper sits on a mobile base or a leg: tests/placement_robot.py)
has them asked again without the bumper, keeps the bumper on its base, and the trace names the restriction that
fired."""
from __future__ import annotations

import json
from io import StringIO

import pytest

from tests.placement_robot import TAX, Robot, build, model
from tests.scripted_reasoner import scripted_placements, scripted_reasoner
from urdfkb.pipeline.abstraction.abstractor import Abstractor
from urdfkb.pipeline.reading.ingest import load_urdf
from urdfkb.pipeline.llm.base import Question
from urdfkb.pipeline.llm.scripted import ScriptedBackend
from urdfkb.pipeline.abstraction.oracle import Oracle


def run(seed: int) -> tuple[Robot, dict, list[dict], list[Question]]:
    """The robot, its components by leaf, the trace's placement records and the questions asked."""
    robot, trace = build(seed), StringIO()
    asked: list[Question] = []
    abstractor = Abstractor(Oracle(ScriptedBackend(model(robot, asked)), trace=trace), TAX,
                            reasoner=scripted_reasoner, placer=scripted_placements)
    components = abstractor.run(load_urdf(robot.urdf)).components
    records = [json.loads(line) for line in trace.getvalue().splitlines()]
    by_leaf = {link: c for c in components for link in c.links}
    return robot, by_leaf, [r for r in records if r["key"] == "placement"], asked


@pytest.mark.parametrize("seed", range(3))
def test_a_bumper_on_the_torso_is_asked_again_and_the_restriction_recorded(seed):
    robot, by_leaf, fired, asked = run(seed)
    button, pad, bumper = by_leaf[robot.button], by_leaf[robot.pad[0]], by_leaf[robot.bumper]
    assert (button.cls, pad.cls, bumper.cls) == ("Button", "TactileArray", "Bumper")
    assert by_leaf[robot.pad[1]] is pad and button.located_on.startswith("torso_") and bumper.located_on.startswith("mobile_base")
    assert [(r["component"], r["class"], r["part_class"], r["reasked"]) for r in fired] == [
        (button.name, "Bumper", "Torso", "Button"), (pad.name, "Bumper", "Torso", "TactileArray")]
    assert {r["restriction"] for r in fired} == {"Bumper ⊑ ∀isLocatedOn.(MobileBase ⊔ Leg)"}
    reasked = [q for q in asked if q.key.startswith("placement:")]
    assert reasked and all("bumper" not in q.options for q in reasked)  # the same questions, without the bumper
    first = next(q for q in asked if q.key == f"pre:{robot.button}@Sensor")
    again = next(q for q in reasked if q.key == f"placement:{robot.button}@Sensor")
    assert (again.system, again.user) == (first.system, first.user)
    assert any(q.user.startswith("Frames: ") and q.key == f"placement:{robot.pad[0]}@Sensor" for q in reasked)


def test_nothing_is_asked_again_where_every_class_fits_its_place():
    """Without the body pass's torso (the model calls the lift nothing), the button sits on the mobile base,
    where a bumper may: it stays one."""
    robot, asked = build(0), list[Question]()
    rule = model(robot, asked)
    abstractor = Abstractor(Oracle(ScriptedBackend(lambda q: "none" if q.key.startswith("body:") else rule(q))), TAX,
                            reasoner=scripted_reasoner, placer=scripted_placements)
    by_leaf = {link: c for c in abstractor.run(load_urdf(robot.urdf)).components for link in c.links}
    button = by_leaf[robot.button]
    assert button.cls == "Bumper" and (button.located_on or "").startswith("mobile_base")
    assert not any(q.key.startswith("placement:") for q in asked)


def test_a_component_asked_again_keeps_the_doubt_about_its_kind():
    """The model takes the button for a sensor by 0.6 of its votes: asked again for its class, it keeps that
    factor (its confidence the new class's share times 0.6, as every device's is)."""
    robot, asked = build(0), list[Question]()
    rule = model(robot, asked)

    def doubting(q: Question):
        answer = rule(q)
        if q.key.startswith(f"identify:{robot.button}"):
            other = next(o for o in q.options if o != answer)
            return {answer: 0.6, other: 0.4}
        return answer
    trace = StringIO()
    abstractor = Abstractor(Oracle(ScriptedBackend(doubting), trace=trace), TAX,
                            reasoner=scripted_reasoner, placer=scripted_placements)
    button = next(c for c in abstractor.run(load_urdf(robot.urdf)).components if robot.button in c.links)
    (fired,) = [r for line in trace.getvalue().splitlines() if (r := json.loads(line))["key"] == "placement"
                and r["component"] == button.name]
    assert button.cls == "Button" and button.kind_share == 0.6
    assert button.confidence == pytest.approx(fired["confidence"] * 0.6, abs=1e-4)
