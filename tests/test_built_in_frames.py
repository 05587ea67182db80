"""Generated sensor heads where a device's own IMU frame is its only leaf (a lidar written as a housing frame
with its built-in IMU's frame below): the model types that frame an IMU, as the small model does, and the
device is still what its housing is (pipeline.abstraction.steps.classify.built_in_frames, the ontology's core:builtIn). A housing
that is an IMU of its own, that carries another leaf too (as a palm carries fingers), or that the model
cannot place (a bracket: no kind with the majority of the votes) changes nothing."""
from __future__ import annotations

import random

import pytest

from tests.built_in_robots import build, reads_frames
from tests.scripted_reasoner import scripted_reasoner
from tests.toy_robot import LABELS, TAX
from tests.urdf_writer import Writer
from urdfkb.pipeline.abstraction.abstractor import Abstractor
from urdfkb.pipeline.reading.ingest import load_urdf
from urdfkb.pipeline.llm.base import Question
from urdfkb.pipeline.llm.scripted import ScriptedBackend
from urdfkb.pipeline.abstraction.oracle import Oracle

SEEDS = range(60)


@pytest.mark.parametrize("seed", SEEDS)
def test_a_frame_built_into_a_device_takes_the_devices_kind(seed):
    urdf, head, truth, frame_of, expected = build(seed)
    oracle = Oracle(ScriptedBackend(reads_frames(head, truth, frame_of)))
    sensors = [c for c in Abstractor(oracle, TAX, reasoner=scripted_reasoner).run(load_urdf(urdf)).components
               if c.kind == "sensor"]
    typed = {link: c.cls for c in sensors for link in c.links if link in frame_of}
    assert typed == expected, seed


@pytest.mark.slow  # over a second of its own (make test-fast leaves it out)
def test_the_generator_makes_bare_and_boxed_lidars():
    housings = [(truth[h], load_urdf(urdf).evidence.get(h)) for urdf, _, truth, frame_of, _ in map(build, SEEDS)
                for h in frame_of.values()]
    bare = {facts is None or facts.is_pure_frame for cls, facts in housings if cls == "Lidar"}
    assert bare == {True, False}


def _drone(seed: int) -> tuple[bytes, str, str]:
    """A drone's body (below a footprint frame) carrying, as bare frames, a downward camera and a sonar beside it,
    each with its own simulator sensor declared on its frame; its IMU declared on the body itself. The camera's and
    the sonar's frames."""
    w = Writer(random.Random(seed))
    footprint, body = w.link(), w.link('<box size="0.5 0.5 0.1"/>')
    w.joint("fixed", footprint, body, (0.0, 0.0, 0.1))
    camera, sonar = w.link(), w.link()
    w.joint("fixed", body, camera, (0.03, 0.0, -0.05), rpy=(0.0, 1.5708, 0.0))
    w.joint("fixed", body, sonar, (-0.03, 0.0, -0.05), rpy=(0.0, 1.5708, 0.0))
    w.joints.append(f'<gazebo reference="{body}"><sensor name="imu" type="imu"/></gazebo>')
    w.joints.append(f'<gazebo reference="{camera}"><sensor name="down" type="camera"><camera><horizontal_fov>1.0'
                    '</horizontal_fov><image><width>640</width><height>360</height></image></camera></sensor></gazebo>')
    w.joints.append(f'<gazebo reference="{sonar}"><sensor name="sonar" type="ray"><ray><scan><horizontal><samples>3'
                    '</samples><min_angle>-0.12</min_angle><max_angle>0.12</max_angle></horizontal></scan><range>'
                    '<min>0.01</min><max>3.0</max></range></ray></sensor></gazebo>')
    return w.urdf(), camera, sonar


@pytest.mark.parametrize("seed", range(3))
def test_a_frame_declared_a_sonar_beside_a_camera_is_no_built_in_frame_of_it(seed):
    """Two bare frames on one body: a camera's and a sonar's, each declared on its own frame. Frames of one body bind
    to the one called a vision sensor whatever their own category (a camera's own IMU frames belong to it), so the
    sonar was bound into the camera as a colour frame. A frame declared a sensor no camera carries measures apart."""
    urdf, camera, sonar = _drone(seed)
    truth = {camera: "MonocularCamera", sonar: "Sonar"}

    def answer(q: Question) -> str | dict[str, float]:
        stage, _, subject = q.key.partition(":")
        subject = subject.partition("@")[0]
        if stage in ("identify", "check"):
            return "sensor" if subject in truth else q.options[-1]
        if stage == "pre" and subject in truth:
            return next(o for o in q.options if o in LABELS and TAX.is_a(truth[subject], LABELS[o]))
        if stage == "root":  # the camera mounted on the frame above the body, as the small model may answer
            return q.options[-1] if subject == camera else q.options[0]
        return q.options[0]
    sensors = [c for c in Abstractor(Oracle(ScriptedBackend(answer)), TAX, reasoner=scripted_reasoner)
               .run(load_urdf(urdf)).components if c.kind == "sensor"]
    assert sorted((c.cls, sorted(c.links)) for c in sensors) == sorted(
        [("MonocularCamera", [camera]), ("Sonar", [sonar])]), seed
