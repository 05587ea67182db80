#!/usr/bin/env python3
"""Ask a robot held by a running urdfkb server three questions about its own body, and print the
answers as plain sentences:

    which of your links are cameras?
    what is on your head?
    which joints move your left arm?

    urdfkb serve --populate pr2.urdf &        # or: make run (the TurtleBot3 sample)
    python examples/ask_the_robot.py --url http://127.0.0.1:8000 --robot pr2

Everything goes through urdfkb.client (standard library HTTP). Exit status 0 when every question was
answered, 1 when the server could not be asked (down, unknown robot, refused query), 2 for bad arguments.
"""
from __future__ import annotations

import argparse
import math
import sys

from urdfkb.client import ClientError, KnowledgeBase, class_words

NUMBERS = "no one two three four five six seven eight nine ten eleven twelve".split()


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="Ask a robot in a running urdfkb server about its body.")
    parser.add_argument("--url", default="http://127.0.0.1:8000", help="the server (default: %(default)s)")
    parser.add_argument("--robot", help="the robot's name in the server (default: its only robot)")
    parser.add_argument("--token", help="bearer token, where the server or a proxy in front wants one")
    args = parser.parse_args(argv)
    try:
        kb = KnowledgeBase(args.url, token=args.token)
    except ValueError as e:
        parser.error(str(e))
    try:
        robot = args.robot or only_robot(kb)
        for question, answer in (("Which of your links are cameras?", cameras(kb, robot)),
                                 ("What is on your head?", on_head(kb, robot)),
                                 ("Which joints move your left arm?", left_arm(kb, robot))):
            print(f"Q: {question}\nA: {answer}\n")
    except ClientError as e:
        print(f"ask_the_robot: {e}", file=sys.stderr)
        return 1
    return 0


def only_robot(kb: KnowledgeBase) -> str:
    names = kb.robots()
    if len(names) != 1:
        raise SystemExit(f"ask_the_robot: say which robot with --robot (the server holds "
                         f"{', '.join(names) if names else 'none'})")
    return names[0]


def cameras(kb: KnowledgeBase, robot: str) -> str:
    by_camera: dict[tuple[str, str], list[str]] = {}
    for link in kb.cameras(robot):
        by_camera.setdefault((link.camera, link.cls), []).append(link.link)
    if not by_camera:
        return "None of my links is a camera."
    links = sum(len(v) for v in by_camera.values())
    groups = [f"{listed(sorted(names))} ({'it belongs' if len(names) == 1 else 'they belong'} to my {camera}, "
              f"{article(class_words(cls))})" for (camera, cls), names in by_camera.items()]
    return f"{count(links, 'of my links is', 'of my links are').capitalize()} cameras: {'; '.join(groups)}."


def on_head(kb: KnowledgeBase, robot: str) -> str:
    heads = [p for p in kb.body_parts(robot) if p.cls == "Head"]
    if not heads:
        return "I have no head that I know of."
    things = kb.located_on(robot, "head")
    if not things:
        return "Nothing is located on my head."
    items = [f"my {c.name} ({article(c.label or class_words(c.cls))}, mounted on {c.mount})" for c in things]
    return f"On my head {'is' if len(items) == 1 else 'are'} {listed(items)}."


def left_arm(kb: KnowledgeBase, robot: str) -> str:
    joints = kb.body_part_joints(robot, "arm", side="left")
    if not joints:
        arms = [p for p in kb.body_parts(robot) if p.cls == "Arm"]
        if not arms:
            return "I have no arm that I know of."
        sides = sorted({p.side for p in arms if p.side})
        return f"I have no left arm: my {'arms are' if len(arms) > 1 else 'arm is'} " + (
            f"on the {listed(sides)}." if sides else "not on a side.")
    parts = {j.part for j in joints}
    text = f"{count(len(joints), 'joint moves', 'joints move').capitalize()} my left arm, from the root out: " + \
        f"{listed([describe(j) for j in joints])}."
    return text if len(parts) == 1 else text + f" (They belong to {listed(sorted(parts))}.)"


def describe(joint) -> str:
    """'l_elbow_flex_joint (revolute, from -133.0° to 0.0°)'."""
    facts = [joint.type or "joint"]
    if joint.lower is not None and joint.upper is not None:
        if joint.type == "prismatic":
            facts.append(f"from {joint.lower:g} m to {joint.upper:g} m")
        else:
            facts.append(f"from {math.degrees(joint.lower):.1f}° to {math.degrees(joint.upper):.1f}°")
    elif joint.type == "continuous":
        facts.append("turns without limit")
    return f"{joint.name} ({', '.join(facts)})"


def listed(items: list[str]) -> str:
    return items[0] if len(items) == 1 else ", ".join(items[:-1]) + " and " + items[-1]


def count(n: int, one: str, many: str) -> str:
    return f"{NUMBERS[n] if n < len(NUMBERS) else n} {one if n == 1 else many}"


def article(phrase: str) -> str:
    """'a stereo camera', 'an IMU', 'an RGB-D camera'."""
    first = phrase.split()[0] if phrase else ""
    vowel = first[:1].lower() in "aeiou" if not first.isupper() else first[:1] in "AEFHILMNORSX"
    return f"{'an' if vowel else 'a'} {phrase}"


if __name__ == "__main__":
    sys.exit(main())
