"""examples/ask_the_robot.py run as a program against a live server on 127.0.0.1."""
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import pytest

from tests.kb_fixtures import PR2_WHOLE, copied, free_port, served
from urdfkb.kb_server.store import Store

pytestmark = pytest.mark.slow  # the example runs in a subprocess

SCRIPT = Path(__file__).resolve().parents[1] / "examples" / "ask_the_robot.py"


@pytest.fixture(scope="module")
def url(whole_pr2_kb, pr2_tree, tmp_path_factory):
    store = Store(copied(whole_pr2_kb, tmp_path_factory.mktemp("kb")), workers=1)
    store.replace_robot("pr2_right_arm_only", pr2_tree, replace(PR2_WHOLE, body=tuple(p for p in PR2_WHOLE.body if p.name != "l_arm"),
                                                            components=tuple(c for c in PR2_WHOLE.components if c.name != "l_gripper")))
    try:
        with served(store) as base:
            yield base
    finally:
        store.close()


def ask(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(SCRIPT), *args], capture_output=True, text=True, timeout=60)


def test_answers_in_plain_sentences(url):
    run = ask("--url", url, "--robot", "pr2")
    assert run.returncode == 0, run.stderr
    out = run.stdout
    assert "Q: Which of your links are cameras?\nA: Seven of my links are cameras: " in out
    assert ("head_mount_kinect_ir_link, head_mount_kinect_ir_optical_frame and head_mount_kinect_rgb_optical_frame "
            "(they belong to my kinect, an RGBD camera)") in out
    assert "r_forearm_cam_optical_frame (it belongs to my r_forearm_cam, a monocular camera)" in out
    assert ("Q: What is on your head?\nA: On my head are my wide_stereo (a stereo camera, mounted on double_stereo_link), "
            "my kinect (an RGB-D camera, mounted on head_mount_link) and my prosilica (a monocular camera, mounted on "
            "head_mount_link).") in out
    assert ("Q: Which joints move your left arm?\nA: Seven joints move my left arm, from the root out: "
            "l_shoulder_pan_joint (revolute, from -40.9° to 130.9°), l_shoulder_lift_joint (revolute, from -30.0° to 80.0°), "
            "l_upper_arm_roll_joint (revolute, from -45.8° to 223.5°), l_elbow_flex_joint (revolute, from -133.0° to 0.0°), "
            "l_forearm_roll_joint (continuous, turns without limit), l_wrist_flex_joint (revolute, from -124.9° to 0.0°) "
            "and l_wrist_roll_joint (continuous, turns without limit).") in out
    assert run.stderr == ""


def test_a_robot_without_that_body(url):
    out = ask("--url", url, "--robot", "pr2_no_body").stdout
    assert "A: I have no head that I know of." in out and "A: I have no arm that I know of." in out
    out = ask("--url", url, "--robot", "pr2_right_arm_only").stdout
    assert "A: I have no left arm: my arm is on the right." in out


def test_a_server_that_cannot_answer(url):
    run = ask("--url", url, "--robot", "nao")
    assert run.returncode == 1 and "no robot 'nao'" in run.stderr and url in run.stderr and run.stdout == ""
    down = f"http://127.0.0.1:{free_port()}"
    run = ask("--url", down, "--robot", "pr2")
    assert run.returncode == 1 and f"urdfkb server at {down} is unavailable" in run.stderr
    run = ask("--url", url)  # several robots: say which
    assert run.returncode == 1 and "--robot" in run.stderr and "pr2_no_body" in run.stderr
    assert ask("--url", "127.0.0.1:8000").returncode == 2
