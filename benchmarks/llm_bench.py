"""Speed of the embedded llama.cpp backend: cold vs warm prefix, batched vs one question at a time.

Usage: python -m benchmarks.llm_bench [--test-model] [--reps 3]
Prints medians over rounds that interleave the cases. Each question has ~30 user tokens and 5 options of 2-5 tokens.
"""
from __future__ import annotations

import argparse
import os
import statistics
import time
from collections.abc import Callable

from urdfkb.pipeline.llm.base import Question
from urdfkb.pipeline.llm.fetch import DEFAULT_MODEL, TEST_MODEL, ensure_model
from urdfkb.pipeline.llm.llama import LlamaBackend
from urdfkb.pipeline.abstraction.oracle import softmax

SYSTEM = (
    "You classify the links of a robot described by a URDF file. Each question names one link, its parent "
    "chain and its visual mesh. Answer with exactly one category.\n"
    "camera sensor: a link that carries an optical sensor: camera, stereo head, depth or RGB-D sensor, "
    "kinect, webcam, optical frame.\n"
    "force torque sensor: a link that measures forces or torques: ft sensor, load cell, wrist sensor, "
    "tactile pad, pressure sensor.\n"
    "gripper finger: a part of an end effector that grasps: finger, finger tip, palm, jaw, claw, suction cup.\n"
    "drive wheel: a part that rolls on the ground: wheel, caster, track, omni wheel.\n"
    "structural part: everything else: base, torso, arm segment, shoulder, elbow, cover, plate, bracket, "
    "motor housing, screw, LED, cable.\n"
    "Examples: head_mount_kinect_rgb_link -> camera sensor; l_gripper_l_finger_tip_link -> gripper finger; "
    "fl_caster_rotation_link -> drive wheel; r_forearm_roll_link -> structural part."
)
OPTIONS = ("camera sensor", "force torque sensor", "gripper finger", "drive wheel", "structural part")
LINKS = [
    "head_mount_prosilica_link", "l_gripper_r_finger_tip_link", "br_caster_l_wheel_link", "r_upper_arm_roll_link",
    "base_laser_link", "l_force_torque_link", "torso_lift_motor_screw_link", "r_gripper_palm_link",
]


def question(link: str) -> Question:
    user = f"Link: {link}. Parent chain: base_link > torso_lift_link. Mesh: {link}.stl. Which category?"
    return Question(SYSTEM, user, OPTIONS, key=f"kind:{link}")


def run_interleaved(backend: LlamaBackend, cases: list[tuple[str, Callable[[], object], int]], reps: int) -> None:
    """Run every case once per round (so load from other processes hits all alike); print medians."""
    times: dict[str, list[float]] = {label: [] for label, _, _ in cases}
    tokens: dict[str, list[int]] = {label: [] for label, _, _ in cases}
    for _ in range(reps):
        for label, fn, _ in cases:
            before, start = backend.stats.prompt_tokens, time.perf_counter()
            fn()
            times[label].append(time.perf_counter() - start)
            tokens[label].append(backend.stats.prompt_tokens - before)
    for label, _, n in cases:
        seconds, evaluated = statistics.median(times[label]), statistics.median(tokens[label])
        print(f"{label:<44} {seconds / n:7.3f} s/question  {evaluated / n:6.1f} tok/question"
              f"  {evaluated / seconds:6.1f} tok/s")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--test-model", action="store_true", help="SmolLM2-135M instead of the default 1.5B model")
    parser.add_argument("--reps", type=int, default=3)
    args = parser.parse_args()
    spec = TEST_MODEL if args.test_model else DEFAULT_MODEL
    path = ensure_model(spec)
    start = time.perf_counter()
    backend = LlamaBackend(path)
    print(f"model {spec.filename}: load {time.perf_counter() - start:.1f} s, {os.cpu_count()} threads, "
          f"load average {os.getloadavg()[0]:.1f}")
    qs = [question(link) for link in LINKS]
    one = qs[0]
    print(f"prefix {len(backend.prefix_tokens(SYSTEM))} tokens; full prompt {len(backend.prompt_tokens(one))} tokens; "
          f"user text {len(backend.option_tokens(one.user))} tokens; "
          f"options {[len(backend.option_tokens(o)) for o in OPTIONS]} tokens; {len(qs)} questions per batch")

    def cold():
        backend.reset()
        backend.score([one])

    backend.score([one])  # warm-up: first decode allocates buffers
    run_interleaved(backend, [
        ("cold prefix, 1 question (prefix + question)", cold, 1),
        ("warm prefix, 1 question", lambda: backend.score([one]), 1),
        (f"warm prefix, {len(qs)} questions one at a time", lambda: [backend.score([q]) for q in qs], len(qs)),
        (f"warm prefix, {len(qs)} questions in one batch", lambda: backend.score(qs), len(qs)),
        ("sample 5 votes, 1 question (grammar)", lambda: backend.sample(one, 5, 0.7), 1),
    ], args.reps)
    print(f"load average at the end {os.getloadavg()[0]:.1f}")

    batched = backend.score(qs)
    alone = [backend.score([q])[0] for q in qs]
    d_logprob = max(abs(a - b) for ra, rb in zip(batched, alone) for a, b in zip(ra, rb))
    d_prob = max(abs(a - b) for ra, rb in zip(batched, alone) for a, b in zip(softmax(ra), softmax(rb)))
    print(f"batched vs alone: max |d log-prob| {d_logprob:.4f}, max |d probability| {d_prob:.4f}")
    for q, row in zip(qs, batched):
        probs = softmax(row)
        best = max(range(len(OPTIONS)), key=probs.__getitem__)
        print(f"  {q.key:<38} {OPTIONS[best]:<20} {probs[best]:.2f}")
    backend.close()


if __name__ == "__main__":
    main()
