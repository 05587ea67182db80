"""Questions in words (kb_server.ask) with the scripted backend standing in for the model: the options the
knowledge base offers, the choice and its threshold, the reply and its sentence, GET /ask and the client;
and once with the small real model."""
from __future__ import annotations

import json

import pytest

from tests.ask_robots import store_ask_robots
from tests.kb_fixtures import client, copied, make_app, served
from urdfkb.client import KnowledgeBase
from urdfkb.kb_server.ask import Asker, QuestionError, direct
from urdfkb.kb_server.ask_options import build_menu
from urdfkb.kb_server.queries import load_queries
from urdfkb.kb_server.store import Store, UnknownRobot
from urdfkb.pipeline.llm.base import Question
from urdfkb.pipeline.llm.scripted import ScriptedBackend


@pytest.fixture(scope="module")
def ask_kb(pr2_tree, tmp_path_factory):
    s = Store(tmp_path_factory.mktemp("ask") / "kb.sqlite3", workers=0)
    store_ask_robots(s, pr2_tree)
    s.close()
    return s.path


@pytest.fixture(scope="module")
def kb(ask_kb, tmp_path_factory):
    s = Store(copied(ask_kb, tmp_path_factory.mktemp("kb")), workers=0)
    yield s
    s.close()


def scripted(answer):
    """An Asker whose model answers `answer` (an option, or a distribution), and the questions it was asked."""
    asked: list[Question] = []

    def rule(q: Question):
        asked.append(q)
        return answer
    return Asker(direct(ScriptedBackend(rule))), asked


def options(kb, robot, text):
    return {c.option: dict(c.params) for c in build_menu(kb, robot).choices(text)}


def test_options_come_from_the_robot(kb):
    pr2 = options(kb, "pr2", "what is on you?")
    assert pr2["arm_reach"] == {"side": "any"} and pr2["cameras"] == {} and pr2["none"] == {}
    assert pr2["located_on arm"] == {"part": "Arm", "side": "any"} and pr2["located_on head"] == {"part": "Head"}
    assert {"body_part_joints mobile base", "body_part_joints torso", "body_part_joints wheel"} <= set(pr2)
    turtlebot = build_menu(kb, "turtlebot3")
    assert not any(o.startswith("located_on arm") for o in options(kb, "turtlebot3", "what is on you?"))
    assert "lidar" in turtlebot.system and "mobile base" in turtlebot.system
    assert "A question naming one of the robot's body parts or links is about its body." in turtlebot.system
    reach = load_queries()["arm_reach"]  # each query's title and `# in words` line are the menu
    assert reach.in_words.startswith("how far an arm reaches") and f"arm_reach: {reach.title}; asked as: {reach.in_words}" in turtlebot.system
    assert all(q.in_words for q in load_queries().values())
    assert not any(o.startswith("mounted_below") for o in options(kb, "turtlebot3", "what can you see?"))


def test_code_fixes_the_values_the_question_names(kb):
    left = options(kb, "pr2", "How far can you reach with your lefft arm?")
    assert left["arm_reach"] == {"side": "left"} and left["located_on"] == {"part": "Arm", "side": "left"}
    assert options(kb, "pr2", "reach of your left and right arms")["arm_reach"] == {"side": "any"}
    assert options(kb, "pr2", "what is on your rigth arm")["located_on"] == {"part": "Arm", "side": "right"}
    head = options(kb, "pr2", "what is on your left head")  # the head has no side
    assert head["located_on"] == {"part": "Head"} and head["body_part_joints"] == {"part": "Head"}
    assert options(kb, "pr2", "what is on your base?")["located_on"] == {"part": "MobileBase"}
    both = options(kb, "pr2", "is there a camera on your head or on your arms?")
    assert both["located_on head"] == {"part": "Head"} and "located_on torso" not in both
    wheels = options(kb, "turtlebot3", "joints of your right wheels")
    assert wheels["body_part_joints"] == {"part": "Wheel", "side": "right"}
    assert options(kb, "turtlebot3", "what is mounted below your base scan link?")["mounted_below"] == {"link": "base_scan"}
    links = options(kb, "pr2", "what is under head_pan_link or torso_lift_link?")
    assert {o: v for o, v in links.items() if o.startswith("mounted_below")} == {
        "mounted_below head_pan_link": {"link": "head_pan_link"}, "mounted_below torso_lift_link": {"link": "torso_lift_link"}}


def test_a_question_is_answered_by_its_query(kb):
    asker, asked = scripted("arm_reach")
    reply = asker.ask(kb, "pr2", "How far can you reach with your left arm?")
    assert reply["query"] == "arm_reach" and reply["params"] == {"side": "left"} and not reply["refused"]
    (row,) = reply["rows"]
    assert row["side"] == "left" and row["degreesOfFreedom"] == 7 and reply["units"] == {"reach": "m"}
    assert reply["answer"] == ("How far each arm reaches: l_arm (side left, mount torso_lift_link, degrees of freedom 7, "
                               f"reach {row['reach']} m).")
    assert reply["confidence"] == 1.0
    asker.ask(kb, "pr2", "which of your links are cameras?")
    assert asked[0].system == asked[1].system  # one menu a robot: its prompt state is reused
    assert asked[0].user.startswith("How far can you reach with your left arm?\n")  # then what code found it names
    assert asked[1].user == "which of your links are cameras?"


def test_the_model_reads_what_the_question_names(kb):
    menu = build_menu(kb, "pr2")
    assert menu.user(" What is on your rigth arm? ") == "What is on your rigth arm?\n(It names the robot's body part right arm.)"
    assert menu.user("what is under torso_lift_link?") == "what is under torso_lift_link?\n(It names the robot's link torso_lift_link.)"
    assert menu.user("joints of the head and torso") == "joints of the head and torso\n(It names the robot's body part head, torso.)"
    assert menu.user("Where is the kitchen?") == "Where is the kitchen?"  # "where" is no misspelt "wheel"


def test_a_link_s_words_name_no_body_part(kb):
    below = options(kb, "pr2", "what is mounted below torso_lift_link?")
    assert below["mounted_below"] == {"link": "torso_lift_link"} and "located_on torso" in below  # every part: none named
    assert options(kb, "pr2", "what is on your head?")["located_on"] == {"part": "Head"}


def test_cameras_answer_names_them(kb):
    reply = scripted("cameras")[0].ask(kb, "pr2", "which of your links are cameras?")
    assert {"r_forearm_cam_optical_frame", "head_mount_kinect_rgb_optical_frame"} <= {r["link"] for r in reply["rows"]}
    assert reply["answer"].startswith("Which of my links are cameras: head_mount_kinect_ir_link")


def test_none_of_these_is_a_refusal(kb):
    reply = scripted("none")[0].ask(kb, "turtlebot3", "Will it rain tomorrow?")
    assert reply["refused"] and reply["query"] is None and reply["rows"] == []
    assert "outside what I, turtlebot3, know about my body" in reply["answer"]
    assert "how far each arm reaches" in reply["answer"]


def test_probability_is_counted_per_query(kb):
    reply = scripted({"located_on head": 0.3, "located_on torso": 0.25, "cameras": 0.45})[0].ask(kb, "pr2", "on you?")
    assert reply["query"] == "located_on" and reply["params"] == {"part": "Head"} and reply["confidence"] == 0.55
    leading = scripted({"cameras": 0.45, "sensors": 0.35, "none": 0.2})[0].ask(kb, "pr2", "what is that?")
    assert leading["query"] == "cameras" and not leading["refused"] and leading["confidence"] == 0.45
    unsure = scripted({"cameras": 0.28, "sensors": 0.27, "components": 0.25, "none": 0.2})[0].ask(kb, "pr2", "what is that?")
    assert unsure["refused"] and unsure["confidence"] == 0.28


def test_an_empty_robot_answer_says_none(kb):
    reply = scripted("arm_reach")[0].ask(kb, "turtlebot3", "how far can your arm reach?")
    assert reply["rows"] == [] and reply["answer"] == "How far each arm reaches: none."


def test_bad_questions(kb):
    asker, asked = scripted("none")
    with pytest.raises(QuestionError, match="empty"):
        asker.ask(kb, "pr2", "  ")
    with pytest.raises(QuestionError, match="longer than"):
        asker.ask(kb, "pr2", "why " * 200)
    with pytest.raises(UnknownRobot):
        asker.ask(kb, "r2d2", "hello?")
    assert not asked


def test_ask_route(kb):
    app, jobs = make_app(kb, asker=scripted("located_on")[0])
    try:
        call = client(app)
        status, _, body = call("GET", "/ask?robot=pr2&q=what%20is%20on%20your%20head%3F")
        reply = json.loads(body)
        assert status == 200 and reply["query"] == "located_on" and reply["params"] == {"part": "Head"}
        assert {"comp_kinect", "comp_prosilica", "comp_wide_stereo"} <= {r["component"].rsplit("#")[-1] for r in reply["rows"]}
        assert call("GET", "/ask?robot=pr2")[0] == 400
        assert call("GET", "/ask?robot=nobody&q=hi")[0] == 404
    finally:
        jobs.shutdown()
    app, jobs = make_app(kb)  # a fake pipeline runner: no model to read with
    try:
        status, _, body = client(app)("GET", "/ask?robot=pr2&q=hi")
        assert status == 503 and b"no embedded model" in body
    finally:
        jobs.shutdown()


@pytest.mark.slow  # over a second of its own (make test-fast leaves it out)
def test_client_ask(kb):
    with served(kb, asker=scripted("gripper_opening")[0]) as base:
        reply = KnowledgeBase(base).ask("pr2", "How wide do your grippers open?")
    assert reply.query == "gripper_opening" and not reply.refused and len(reply.rows) == 2
    assert reply.answer.startswith("How wide each gripper opens: ")


@pytest.mark.model
def test_small_real_model(kb):
    from urdfkb.pipeline.llm.fetch import TEST_MODEL, ensure_model
    from urdfkb.pipeline.llm.llama import LlamaBackend
    backend = LlamaBackend(ensure_model(TEST_MODEL, progress=False), prefix_cache=False)
    try:
        reply = Asker(direct(backend)).ask(kb, "pr2", "Which of your links are cameras?")
    finally:
        backend.close()
    assert 0 < reply["confidence"] <= 1 and isinstance(reply["answer"], str) and reply["answer"]
    assert reply["refused"] == (reply["query"] is None)


@pytest.mark.slow  # over a second of its own (make test-fast leaves it out)
def test_dialogue_example(kb, capsys):
    import importlib.util
    from pathlib import Path
    spec = importlib.util.spec_from_file_location("dialogue", Path(__file__).resolve().parents[1] / "examples" / "dialogue.py")
    assert spec and spec.loader
    dialogue = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(dialogue)
    with served(kb, asker=scripted("none")[0]) as base:
        assert dialogue.main(["--url", base, "--robot", "turtlebot3", "Will it rain?"]) == 0
        assert dialogue.main(["--url", base, "--robot", "r2d2", "Will it rain?"]) == 1
    out = capsys.readouterr()
    assert "> Will it rain?\nThat question is outside what I, turtlebot3, know about my body." in out.out
    assert "no robot 'r2d2'" in out.err
