"""The steps' declarations are true: every pass runs over generated robots (scripted model and reasoner) with
each step seeing the findings record through a recording proxy, and a step that reads a field it declares
neither in `needs` nor in `makes`, or sets or changes one not in `makes`, fails the test by pass and step."""
from __future__ import annotations

import pytest
import copy
import hashlib
import json
import random
import re
from pathlib import Path
from typing import Any, Callable

from tests import body_robots, built_in_robots, camera_robots, hand_robots, placement_robot
from tests.scripted_reasoner import scripted_placements, scripted_reasoner
from tests.toy_robot import TOY, perfect
from tests.urdf_writer import Writer
from urdfkb.pipeline.abstraction.abstractor import PASSES, Abstractor
from urdfkb.pipeline.reading.ingest import load_urdf
from urdfkb.pipeline.llm.base import Question
from urdfkb.pipeline.llm.scripted import ScriptedBackend
from urdfkb.pipeline.knowledge.ontology import vocabulary
from urdfkb.pipeline.abstraction.oracle import Oracle
from urdfkb.pipeline.abstraction.passes import Pass, Step
from urdfkb.pipeline.abstraction.prompts import NONE
from urdfkb.pipeline.abstraction.steps.findings import FIELDS, Findings

Rule = Callable[[Question], Any]
ROVER = Path(__file__).parent / "data" / "sensor_bot.urdf"  # three rangers numbered as one device's units


class Recording:
    """A findings record as one step sees it: notes each field read and each field set."""

    def __init__(self, found: Findings):
        object.__setattr__(self, "_found", found)
        object.__setattr__(self, "_read", set())
        object.__setattr__(self, "_set", set())

    def __getattr__(self, name: str) -> Any:
        self._read.add(name)
        return getattr(self._found, name)

    def __setattr__(self, name: str, value: Any) -> None:
        self._set.add(name)
        setattr(self._found, name, value)


Used = dict[Step, tuple[set[str], set[str]]]  # a declared step → the fields it read, those it wrote


def checked(declared: Pass, s: Step, wrong: set[str], used: Used) -> Step:
    """Step `s` of pass `declared` run through a Recording; what it reads or writes undeclared goes into `wrong`,
    what it reads and writes into `used`. A field changed in place (a dict updated) counts as written."""
    def run(context, found: Findings) -> None:
        before = {name: copy.deepcopy(getattr(found, name)) for name in FIELDS}
        seen = Recording(found)
        s.run(context, seen)
        written = seen._set | {name for name in FIELDS if getattr(found, name) != before[name]}
        reads, writes = used.setdefault(s, (set(), set()))
        reads.update(seen._read)
        writes.update(written)
        where = f"pass {declared.name!r}, step {s.name!r}"
        if read := sorted(seen._read - set(s.needs) - set(s.makes)):
            wrong.add(f"{where} reads {', '.join(read)}, undeclared")
        if made := sorted(written - set(s.makes)):
            wrong.add(f"{where} writes {', '.join(made)}, undeclared")
    return Step(s.name, run, s.needs, s.makes)


def hashed(salt: str) -> Rule:
    """A deterministic stand-in model: probabilities from a hash of each question (as benchmarks.transcript)."""
    def rule(q: Question) -> dict[str, float]:
        text = json.dumps([salt, q.system, q.user, q.options])
        weights = [int.from_bytes(hashlib.sha256((text + o).encode()).digest()[:4], "big") + 1 for o in q.options]
        return {o: w / sum(weights) for o, w in zip(q.options, weights)}
    return rule


def identifying(kinds: dict[str, str], salt: str, device: Callable[[str], str] | None = None,
                default: str | None = None) -> Rule:
    """The hashed model, but identifying each leaf in `kinds` as its kind (the others as `default`, if given),
    and naming each leaf's device by `device`."""
    other = hashed(salt)

    def rule(q: Question) -> Any:
        stage, _, subject = q.key.partition(":")
        subject = subject.partition("@")[0]
        if stage == "identify" and (subject in kinds or default):
            return kinds.get(subject, default)
        if stage == "device" and device:
            return device(subject)
        return other(q)
    return rule


def mimic_flag() -> tuple[bytes, Rule]:
    """A base with a wheel and a flag moving on a mimic joint of the wheel's, which the model calls a sensor."""
    w = Writer(random.Random(1))
    base = w.link('<box size="0.4 0.3 0.1"/>')
    spin = w.joint("continuous", base, w.link('<cylinder radius="0.08" length="0.04"/>'), (0, 0.2, 0), (0, 1, 0))
    flag = w.link()
    w.joint("revolute", base, flag, (0.2, 0, 0.1), mimic=spin)
    return w.urdf(), identifying({flag: "sensor"}, "")


def joined_head() -> tuple[bytes, Rule]:
    """A neck carrying a tilting unit and a turning ring, each called a head: one head, joined at assembly."""
    w = Writer(random.Random(2))
    base = w.link('<box size="0.4 0.4 0.2"/>')
    neck, unit, ring = w.link('<box size="0.05 0.05 0.1"/>'), w.link('<box size="0.1 0.2 0.05"/>'), \
        w.link('<cylinder radius="0.1" length="0.02"/>')
    w.joint("revolute", base, neck, (0, 0, 0.3), (0, 0, 1))
    w.joint("revolute", neck, unit, (0, 0, 0.1), (0, 1, 0))
    w.joint("revolute", neck, ring, (0, 0, 0.05), (0, 0, 1))
    return w.urdf(), lambda q: "head" if q.key.startswith("body:") else "none" if "none" in q.options else q.options[0]


def robots() -> list[tuple[str, bytes | Any, Rule]]:
    """Generated robots, each with a model that takes its pass through every kind of step."""
    found: list[tuple[str, bytes | Any, Rule]] = [("toy", TOY, perfect)]
    for seed in range(2):
        placed = placement_robot.build(seed)
        found.append((f"placement {seed}", placed.urdf, placement_robot.model(placed, [])))
    for seed in range(4):
        cameras = camera_robots.build(seed, bare=seed % 2 == 1)
        frames = {f: "sensor" for d in cameras.devices for f in d}
        found.append((f"cameras {seed}", cameras.urdf, identifying(frames, str(seed))))
        found.append((f"hand {seed}", hand_robots.build(seed).urdf, hashed(str(seed))))
    for seed in range(2):
        urdf, head, truth, frame_of, _ = built_in_robots.build(seed)
        found.append((f"built-in {seed}", urdf, built_in_robots.reads_frames(head, truth, frame_of)))
        found.append((f"legged {seed}", body_robots.legged(seed).urdf, hashed(str(seed))))
        found.append((f"wheeled {seed}", body_robots.wheeled(seed).urdf, hashed(str(seed))))
    found.append(("legged, tools everywhere", body_robots.legged(0).urdf, identifying({}, "", default="end effector")))
    rangers = ("nose_scanner", "mast_eye_optical", "tail_scanner", "echo_1_link", "echo_2_link", "echo_3_link")
    rover = identifying(dict.fromkeys(rangers, "sensor"), "", default=NONE,
                        device=lambda leaf: "echo" if leaf.startswith("echo") else leaf)
    found.append(("rover", ROVER.read_bytes(), rover))
    # its echo rangers undeclared, so that one device name for them reaches the numbered-units split
    found.append(("rover, echoes undeclared",
                  re.sub(rb'<gazebo reference="echo_\d_link">.*?</gazebo>', b"", ROVER.read_bytes()),
                  lambda q: "sensor" if q.key.startswith("check:") else q.options[0] if q.key.startswith("pre:echo")
                  else rover(q)))
    found.append(("mimic flag", *mimic_flag()))
    found.append(("joined head", *joined_head()))
    return found


def run_checked(passes: tuple[Pass, ...]) -> tuple[set[str], Used]:
    """Every robot through `passes`, each step checked; what was undeclared, and what each step that ran used."""
    wrong: set[str] = set()
    used: Used = {}
    watched = tuple(Pass(p.name, tuple(checked(p, s, wrong, used) for s in p.steps)) for p in passes)
    vocab = vocabulary()
    for _name, urdf, rule in robots():
        Abstractor(Oracle(ScriptedBackend(rule)), vocab, reasoner=scripted_reasoner, placer=scripted_placements,
                   passes=watched).run(load_urdf(urdf))
    return wrong, used


@pytest.mark.slow  # over a second of its own (make test-fast leaves it out)
def test_every_step_reads_and_writes_only_what_it_declares():
    wrong, used = run_checked(PASSES)
    assert not wrong, "\n".join(sorted(wrong))
    assert set(used) == {s for p in PASSES for s in p.steps}  # every step of every pass was checked
    unused = [f"step {s.name!r} ({s.run.__name__}) never reads {sorted(set(s.needs) - reads)} "
              f"or writes {sorted(set(s.makes) - writes)}"
              for s, (reads, writes) in used.items() if set(s.needs) - reads or set(s.makes) - writes]
    assert not unused, "\n".join(unused)  # nor declares what it never uses


def test_the_check_finds_a_step_reading_and_writing_fields_it_does_not_declare():
    """The sensor pass's sensor check, declared as reading only the leaves and claims, updating no claims."""
    sensor = PASSES[0]
    i = next(i for i, s in enumerate(sensor.steps) if s.name == "sensor check")
    hidden = Step("sensor check", sensor.steps[i].run, needs=("leaves",))
    passes = (Pass(sensor.name, (*sensor.steps[:i], hidden, *sensor.steps[i + 1:])), *PASSES[1:])
    wrong, _used = run_checked(passes)
    assert "pass 'sensor', step 'sensor check' reads claims, shares, undeclared" in wrong
    assert "pass 'sensor', step 'sensor check' writes claims, undeclared" in wrong


def test_a_fresh_robot_starts_from_empty_findings():
    """Nothing the last robot left reaches the next: not a hand's leaves, not the claims on leaves it lacks."""
    abstractor = Abstractor(Oracle(ScriptedBackend(hashed(""))), vocabulary(), reasoner=scripted_reasoner)
    first = abstractor.run(load_urdf(hand_robots.build(0).urdf))
    assert first.hand_mounts and first.claims
    placed = load_urdf(placement_robot.build(0).urdf)
    second = abstractor.run(placed)
    assert not second.hand_mounts and set(second.claims) <= set(placed.leaves())
