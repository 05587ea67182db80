"""Generated sensor heads where a device's own IMU frame is its only leaf (a lidar written as a housing frame
with its built-in IMU's frame below): the model types that frame an IMU, as the small model does, and the
device is still what its housing is (pipeline.abstraction.steps.classify.built_in_frames, the ontology's core:builtIn). A housing
that is an IMU of its own, that carries another leaf too (as a palm carries fingers), or that the model
cannot place (a bracket: no kind with the majority of the votes) changes nothing."""
from __future__ import annotations

import pytest

from tests.built_in_robots import build, reads_frames
from tests.scripted_reasoner import scripted_reasoner
from tests.toy_robot import TAX
from urdfkb.pipeline.abstraction.abstractor import Abstractor
from urdfkb.pipeline.reading.ingest import load_urdf
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
