"""Random but plausible arms ending in a gripper or a hand, with the truth of what was built.

`build(seed, alone=True)` builds the gripper or hand on its own (no arm: the flange is the URDF's
root), as hand and gripper descriptions are often published.

Names are meaningless (a seeded random stem per link and joint), so whatever a test asserts comes
from structure alone. An arm of 4-7 revolute joints ends in one of:
- a *gripper*: two jaws, sliding (prismatic) or pivoting (revolute), the second jaw sometimes a
  <mimic> of the first (multiplier -1 or 1, its axis written to match);
- a *radial hand* (no thumb): 3-5 fingers evenly spaced around the palm's axis, each closing
  towards the axis, straight at the middle of their ranges;
- a *thumbed hand*: 2-4 fingers side by side in a row curling the same way, an abduction joint
  first on some of them, and a thumb in front of the palm facing them, hung on the palm, on a base link fixed to it, or
  on a base link turning about the thumb's own length (an opposition joint).
Fingers have 1-4 joints; joints of one finger are sometimes coupled to its first flexion joint by
<mimic> (multipliers 0.8, 1, 1.2). Fingers hang on a palm (bolted to the flange, or to an adapter
plate on it) or straight on the arm's last moving link; fingertip frames (fixed links at the tips)
and a TCP frame are optional. `asides=True` also bolts a small box on the arm's first moving link and, where
the hand has a palm, one on the link the palm is bolted to, beside the hand: bodies at no limb's end.
`linkages=True` adds four-bar linkages written as branches (cranks beside the fingers, bars on their pins): the
cranks are mechanisms (`Built.linkages`), the bars their fingers' links.

The truth (`Built`) follows pipeline/abstraction/structure.py's definitions and the ontology's class
definitions: the mount is the link the palm is bolted to (the flange, or the adapter), or the
flange when the fingers hang straight on it; a finger chain starts at the first link hung on the
palm's rigid body by a moving joint, its drive is that joint. Kinds: two opposing jaws are a
ParallelGripper; a radial hand a MultiFingerGripper (each finger opposes two or more others, none
moves with another, so none is a ThumbChain); a thumbed hand with two fingers a MultiFingerGripper
(three chains), with three or more fingers an AnthropomorphicHand (the thumb opposes fingers that
move together).
"""
from __future__ import annotations

import math
import random
from dataclasses import dataclass, field

from tests.urdf_writer import Writer


@dataclass
class Chain:
    links: list[str]           # top first, the tip frame included
    drive: str                 # joint name
    motion: str                # prismatic | pivoting
    mimics: str | None = None  # first link of the chain whose joint this one's drive follows
    role: str = "finger"       # jaw | finger | radial | thumb

    @property
    def name(self) -> str:
        return self.links[0]


@dataclass
class Built:
    urdf: bytes
    layout: str                # gripper | radial | thumbed
    kind: str                  # the ontology class the reasoner should infer
    mount: str
    fork: str
    links: set[str]            # the tool's links (the mount excluded)
    leaves: list[str]          # the tool's leaf links
    chains: list[Chain]
    flange: str                # the arm's last moving link
    description: str = ""
    thumb: str | None = None   # first link of the thumb chain
    notes: list[str] = field(default_factory=list)
    asides: list[str] = field(default_factory=list)  # boxes along the arm and beside the hand (asides=True)
    linkages: list[str] = field(default_factory=list)  # first links of the fingers' cranks (linkages=True)
    crank_links: list[str] = field(default_factory=list)  # every link of those cranks

    @property
    def moving_leaves(self) -> set[str]:
        """The tool's leaves on its fingers and their cranks (not a TCP frame fixed to its palm)."""
        on = set(self.crank_links).union(*(c.links for c in self.chains))
        return {leaf for leaf in self.leaves if leaf in on}


def _free(rng: random.Random) -> tuple[float, float]:
    """A full turn, as files write one: +-pi, or +-3.14."""
    return rng.choice(((-math.pi, math.pi), (-3.14, 3.14)))


def _along(xyz, axis, rng: random.Random):
    """`xyz` moved 1 cm along `axis`, one way or the other."""
    side = rng.choice((-0.01, 0.01))
    return tuple(x + side * a for x, a in zip(xyz, axis))


def build(seed: int, alone: bool = False, asides: bool = False, linkages: bool = False, apart: bool = False) -> Built:
    """One random arm and end-effector (or, `alone`, the end-effector only); the same seed builds the
    same robot (`asides` adds boxes, and changes nothing else). `linkages`: four-bar linkages written as
    branches, as a URDF tree cannot close a loop. Beside each finger that pivots by a flexing first joint and
    flexes by two joints or more, a crank hung on the same link by a joint of its own at the finger's first joint,
    about the same axis, with a bar at its end, both shorter than the finger, its range sometimes wholly below
    zero, as such files write it;
    on a finger's later pins, where the finger goes on beyond them, a bar beside the joint (on the link before
    it) and one on the link after it, at its origin: short, written continuous, with a range below zero or none.
    `apart`: each crank and bar 1 cm beside its joint along the pin, on a revolute joint turning freely (+-pi or
    +-3.14), as some descriptions of underactuated hands write their linkages."""
    rng = random.Random(seed)
    w = Writer(rng)
    lrng = random.Random(seed + 7919)
    cranks: list[str] = []
    heads: list[str] = []  # each crank's first link

    def bar(parent: str, xyz, axis, side: float) -> list[str]:
        """With `linkages`, a linkage's bar on `parent` pivoting about `axis` at `xyz`, shorter than the finger,
        written continuous (with a range, or none), and the link at its end, off to `side` (x) of the pin, so
        that two bars on one pin do not end in one place: the bar and that link."""
        if not linkages:
            return []
        bar_link, end = w.link(), w.link()
        if apart:
            w.joint("revolute", parent, bar_link, _along(xyz, axis, lrng), axis, _free(lrng))
        else:
            w.joint("continuous", parent, bar_link, xyz, axis, (-1.4, -0.9) if lrng.random() < 0.5 else None)
        w.joint("fixed", bar_link, end, (side * lrng.uniform(0.004, 0.008), 0.0, lrng.uniform(0.004, 0.008)))
        return [bar_link, end]

    def linkage(parent: str, xyz, axis) -> None:
        """A crank on `parent` pivoting about `axis` at `xyz` (a finger's first joint), with a bar at its end."""
        if not linkages:
            return
        crank, bar = w.link(), w.link()
        lower = lrng.uniform(-2.2, -1.0)
        below = lrng.random() < 0.5
        if apart:
            w.joint("revolute", parent, crank, _along(xyz, axis, lrng), axis, _free(lrng))
        else:
            w.joint("revolute", parent, crank, xyz, axis, (lower, lower + 0.9) if below else (-0.5, 0.5))
        w.joint("continuous", crank, bar, (0.0, lrng.uniform(-0.003, 0.003), lrng.uniform(0.006, 0.012)), axis)
        cranks.extend([crank, bar])
        heads.append(crank)
    # the arm
    link = w.link()
    arm = [link]
    for i in range(0 if alone else rng.randint(4, 7)):
        child = w.link()
        arm.append(child)
        w.joint("revolute", link, child, (0.0, 0.0, rng.uniform(0.08, 0.3)),
                (0.0, 0.0, 1.0) if i % 2 == 0 else (0.0, 1.0, 0.0), (-2.5, 2.5))
        link = child
    flange = link
    layout = rng.choice(["gripper", "radial", "thumbed"])
    on_palm = rng.random() < 0.7
    tool_links: set[str] = set()
    if on_palm:
        mount = flange
        if rng.random() < 0.3:  # an adapter plate between flange and palm: the palm is bolted to it
            adapter = w.link()
            w.joint("fixed", flange, adapter, (0.0, 0.0, 0.01))
            mount = adapter
        palm = w.link()
        w.joint("fixed", mount, palm, (0.0, 0.0, rng.uniform(0.01, 0.04)), rpy=(0.0, 0.0, rng.uniform(-math.pi, math.pi)))
        tool_links.add(palm)
        base, base_z = palm, rng.uniform(0.05, 0.1)
    else:
        mount = base = flange
        base_z = rng.uniform(0.01, 0.04)
    tips = rng.random() < 0.5
    chains: list[Chain] = []
    thumb = None

    def segments(parent: str, start, axis, count: int, lengths: tuple[float, float], limits,
                 couple: bool, first_axis=None, first_limits=None, mimic_first=None) -> tuple[list[str], str]:
        """A finger of `count` joints from `start` on `parent`, pointing along the parent's +z."""
        links: list[str] = []
        joints: list[str] = []
        flex = None
        xyz = start
        ends = tips or count - (first_axis is not None) == 1  # a tip frame will follow the last segment
        for j in range(count):
            child = w.link()
            abduct = j == 0 and first_axis is not None
            mimic, mult = None, 1.0
            if j == 0 and mimic_first is not None:
                mimic, mult = mimic_first
            elif not abduct and flex is not None and couple:
                mimic, mult = flex, rng.choice([0.8, 1.0, 1.2])
            lim = first_limits if abduct else limits()
            if j == 0 and not abduct and count - (first_axis is not None) >= 2:  # a crank curls a jointed finger
                linkage(parent, xyz, axis)
            elif j and not abduct and (j < count - 1 or ends):
                links.extend(bar(parent, xyz, axis, -1.0))  # beside the joint into `child`, on the same pin
            joint = w.joint("revolute", parent, child, xyz, first_axis if abduct else axis, lim, mimic, mult)
            if j and not abduct and (j < count - 1 or ends):  # beside the rest of the finger, on the pin `child` turns on
                links.extend(bar(child, (0.0, 0.0, 0.0), axis, 1.0))
            if not abduct and flex is None:
                flex = joint
            joints.append(joint)
            links.append(child)
            parent = child
            xyz = (0.0, 0.0, 0.012) if abduct else (0.0, 0.0, rng.uniform(*lengths))
        if ends:  # a lone flexing joint's own frame sits on its
            # axis, and a joint turning the chain about its length moves nothing: its tip frame shows it move
            tip = w.link()
            w.joint("fixed", parent, tip, xyz if count else start)
            links.append(tip)
        return links, joints[0]  # the first joint drives the finger

    if layout == "gripper":
        prismatic = rng.random() < 0.5
        mimic_mode = rng.choice([None, -1.0, 1.0])
        gap = rng.uniform(0.015, 0.05)
        first_drive = None
        for side in (1.0, -1.0):
            jaw = w.link()
            if prismatic:
                axis = (0.0, -side, 0.0)  # towards the other jaw
                mimic, mult = None, 1.0
                if side < 0 and mimic_mode is not None:
                    mimic, mult = first_drive, mimic_mode
                    axis = (0.0, mimic_mode, 0.0)  # multiplier x axis: still towards the other jaw
                drive = w.joint("prismatic", base, jaw, (0.0, side * gap, base_z), axis, (0.0, gap * 0.9), mimic, mult)
                motion = "prismatic"
            else:
                axis = (side, 0.0, 0.0)  # the tip (+z) moves towards -side y
                mimic, mult = None, 1.0
                if side < 0 and mimic_mode is not None:
                    mimic, mult = first_drive, mimic_mode
                    axis = (-mimic_mode, 0.0, 0.0)
                drive = w.joint("revolute", base, jaw, (0.0, side * gap, base_z), axis, (-0.2, 0.6), mimic, mult)
                motion = "pivoting"
            links = [jaw]
            if rng.random() < 0.5:  # a pad on the jaw
                pad = w.link()
                w.joint("fixed", jaw, pad, (0.0, -side * 0.005, 0.04))
                links.append(pad)
            elif not prismatic or tips:
                pad = w.link()
                w.joint("fixed", jaw, pad, (0.0, 0.0, 0.05))
                links.append(pad)
            first_drive = first_drive or drive
            chains.append(Chain(links, drive, motion, chains[0].name if mimic else None, "jaw"))
        kind = "ParallelGripper"
        description = f"{'sliding' if prismatic else 'pivoting'} jaws, mimic {mimic_mode}"
    elif layout == "radial":
        n = rng.randint(3, 5)
        offset = rng.uniform(0, 2 * math.pi)
        radius = rng.uniform(0.025, 0.05)
        for i in range(n):
            theta = offset + 2 * math.pi * i / n
            axis = (math.sin(theta), -math.cos(theta), 0.0)  # the tip (+z) moves towards the axis
            span = rng.uniform(0.4, 1.2)
            links, drive = segments(base, (radius * math.cos(theta), radius * math.sin(theta), base_z), axis,
                                    rng.randint(1, 4), (0.025, 0.05), lambda s=span: (-s, s), rng.random() < 0.5)
            chains.append(Chain(links, drive, "pivoting", None, "radial"))
        kind = "MultiFingerGripper"
        description = f"radial hand of {n}"
    else:
        k = rng.randint(2, 4)
        spacing = rng.uniform(0.018, 0.025)
        for i in range(k):
            x = (i - (k - 1) / 2) * spacing
            count = rng.randint(1, 4)
            abduct = count >= 3 and rng.random() < 0.5
            links, drive = segments(
                base, (x, 0.0, base_z), (-1.0, 0.0, 0.0), count, (0.025, 0.05),
                lambda: (rng.uniform(-0.2, 0.0), rng.uniform(0.6, 1.2)), rng.random() < 0.5,
                (0.0, 1.0, 0.0) if abduct else None, (-0.3, 0.3))
            chains.append(Chain(links, drive, "pivoting", None, "finger"))
        thumb_mode = rng.choice(["palm", "fixed_base", "turning_base"])
        tx = rng.uniform(-0.5, 0.5) * spacing * k
        ty, tz = rng.uniform(0.06, 0.09), base_z + rng.uniform(0.0, 0.03)  # in front of the palm, facing the fingers
        count = rng.randint(1, 3)
        lim = lambda: (rng.uniform(-0.3, 0.0), rng.uniform(0.8, 1.4))  # noqa: E731
        if thumb_mode == "palm":
            links, drive = segments(base, (tx, ty, tz), (1.0, 0.0, 0.0), count, (0.025, 0.04), lim, rng.random() < 0.5)
        elif thumb_mode == "fixed_base":
            thumb_base = w.link()
            w.joint("fixed", base, thumb_base, (tx, ty, tz), rpy=(rng.uniform(-0.3, 0.3), 0.0, 0.0))
            tool_links.add(thumb_base)
            links, drive = segments(thumb_base, (0.0, 0.0, 0.015), (1.0, 0.0, 0.0), count, (0.025, 0.04), lim,
                                    rng.random() < 0.5)
        else:  # opposition joint: the thumb turns about its own length, then flexes
            links, drive = segments(base, (tx, ty, tz), (1.0, 0.0, 0.0), count + 1, (0.025, 0.04), lim,
                                    rng.random() < 0.5, (0.0, 0.0, 1.0), (-0.4, 0.6))
        chains.append(Chain(links, drive, "pivoting", None, "thumb"))
        thumb = links[0]
        kind = "MultiFingerGripper" if k == 2 else "AnthropomorphicHand"
        description = f"{k} fingers and a thumb ({thumb_mode})"
    for c in chains:
        tool_links.update(c.links)
    tool_links.update(cranks)
    if rng.random() < 0.5:  # a TCP frame
        tcp = w.link()
        w.joint("fixed", base, tcp, (0.0, 0.0, base_z + 0.1))
        tool_links.add(tcp)
    boxes = []
    if asides:
        box = '<box size="0.03 0.02 0.01"/>'
        if len(arm) > 2:
            boxes.append(w.link(box))
            w.joint("fixed", arm[1], boxes[-1], (0.05, 0.0, 0.02))
        if on_palm:
            boxes.append(w.link(box))
            w.joint("fixed", mount, boxes[-1], (0.06, 0.0, 0.0))
    urdf = w.urdf()
    parent_of = {}
    for j in w.joints:
        child = j.split('<child link="')[1].split('"')[0]
        parent_of[child] = j.split('<parent link="')[1].split('"')[0]
    has_child = set(parent_of.values())
    leaves = sorted(x for x in tool_links if x not in has_child)
    return Built(urdf, layout, kind, mount, base, tool_links, leaves, chains, flange,
                 f"{description}, {'on a palm' if on_palm else 'on the flange'}", thumb, asides=boxes,
                 linkages=heads, crank_links=cranks)


def build_open_hand(seed: int, synergy: bool = False) -> Built:
    """A five-fingered hand written open, as humanoid hands often are: 3-4 fingers side by side along the palm's +z,
    each curling into the palm (towards -y) by a first joint whose range lies on one side of zero, its second joint
    often a <mimic>; and a thumb beside the palm pointing sideways (+x), that first swings across the palm (a yaw
    joint about z) and then pitches its tip up towards the fingertips. At the zero pose no fingertip moves towards
    the thumb's tip: the fingers curl across the line to it, and only the thumb closes on them. `synergy`: an
    underactuated hand, one joint on a bare frame hung on the palm (its tendon) that every finger's and the thumb's
    joints follow by <mimic>, directly or through the joint before them; the frame is a leaf of the hand."""
    rng = random.Random(seed)
    w = Writer(rng)
    flange = w.link()
    palm = w.link()
    w.joint("fixed", flange, palm, (0.0, 0.0, 0.02))
    k, spacing, base_z = rng.randint(3, 4), rng.uniform(0.018, 0.024), rng.uniform(0.08, 0.11)
    curl = rng.choice([1.0, -1.0])  # which sign of the range curls the finger: files write both
    chains, tool_links = [], {palm}
    tendon = w.link() if synergy else ""
    source = w.joint("revolute", palm, tendon, (0.0, 0.0, 0.01), (0.0, 0.0, 1.0), (0.0, 1.0)) if synergy else ""
    for i in range(k):
        links, parent, xyz, drive = [], palm, ((i - (k - 1) / 2) * spacing, 0.0, base_z), ""
        for j in range(2):
            child = w.link('<box size="0.015 0.015 0.03"/>' if synergy else "")  # bodies, beside the bare tendon
            limits = (0.0, 1.6) if curl > 0 else (-1.6, 0.0)
            mimic: str | None
            if synergy:  # the first joint follows the tendon, the second the first or the tendon
                mimic, multiplier = (drive, 1.0) if j and rng.random() < 0.5 else (source, 1.6 * curl)
            else:
                mimic, multiplier = (drive if j and rng.random() < 0.7 else None), 1.0
            joint = w.joint("revolute", parent, child, xyz, (curl, 0.0, 0.0), limits, mimic=mimic,
                            multiplier=multiplier)
            drive = drive or joint
            links.append(child)
            parent, xyz = child, (0.0, 0.0, rng.uniform(0.03, 0.045))
        tip = w.link()
        w.joint("fixed", parent, tip, xyz)
        chains.append(Chain([*links, tip], drive, "pivoting", None, "finger"))
    side = rng.choice([1.0, -1.0])
    body = '<box size="0.03 0.015 0.015"/>' if synergy else ""
    yaw_link, pitch_link, tip = w.link(body), w.link(body), w.link()
    yaw = w.joint("revolute", palm, yaw_link, (side * (k * spacing / 2 + 0.01), -0.01, base_z * 0.3),
                  (0.0, 0.0, -side), (0.0, 1.5), mimic=source or None, multiplier=1.5)  # swings its tip across (-y)
    w.joint("revolute", yaw_link, pitch_link, (side * 0.02, 0.0, 0.0), (0.0, -side, 0.0), (0.0, 1.1),
            mimic=yaw if synergy else None, multiplier=round(1.1 / 1.5, 3))  # tip up (+z)
    w.joint("fixed", pitch_link, tip, (side * rng.uniform(0.05, 0.07), 0.0, 0.0))
    chains.append(Chain([yaw_link, pitch_link, tip], yaw, "pivoting", None, "thumb"))
    for c in chains:
        tool_links.update(c.links)
    leaves = sorted([c.links[-1] for c in chains] + ([tendon] if synergy else []))
    return Built(w.urdf(), "thumbed", "AnthropomorphicHand", flange, palm, tool_links | ({tendon} if synergy else set()),
                 leaves, chains, flange, f"open hand of {k} fingers, thumb on the {'+x' if side > 0 else '-x'} side"
                 + (", driven by one tendon joint" if synergy else ""), yaw_link)


def _flat_finger(w: Writer, rng: random.Random, parent: str, xyz, along: float, joints: int,
                 follows: tuple[str, float] | None = None) -> tuple[list[str], str, float]:
    """A finger from `xyz` on `parent` laid flat along `along` * y, curling up by `joints` joints whose ranges lie on
    the side of zero a coin picks (files write both, and mirror some fingers only), the first furthest, the others
    often a <mimic> of it; `follows`: a joint its drive follows and that joint's curl (a finger driven by another).
    Its links (the tip frame last), its drive and its curl."""
    curl = rng.choice([1.0, -1.0])
    links, drive, start, first = [], "", xyz, 1.0
    for j in range(joints):
        child = w.link('<box size="0.02 0.02 0.02"/>')
        reach = rng.uniform(1.6, 2.5) if j == 0 else rng.uniform(0.6, 1.0)  # the first joint curls furthest
        first = reach if j == 0 else first
        limits = (0.0, reach) if curl > 0 else (-reach, 0.0)
        if j:
            mimic, multiplier = (drive if rng.random() < 0.5 else None), round(reach / first, 3)
        else:  # following a finger of the other curl, it turns the other way
            mimic, multiplier = (follows[0], curl * follows[1]) if follows else (None, 1.0)
        joint = w.joint("revolute", parent, child, start, (along * curl, 0.0, 0.0), limits, mimic=mimic,
                        multiplier=multiplier)
        drive = drive or joint
        links.append(child)
        parent, start = child, (0.0, along * rng.uniform(0.05, 0.07), 0.0)
    tip = w.link()
    w.joint("fixed", parent, tip, start)
    return [*links, tip], drive, curl


def build_flat_pair(seed: int) -> Built:
    """A two-finger gripper written fully open, as underactuated ones are: two fingers laid out flat from the palm
    (+y and -y, half a turn apart), each curling up and in by two joints (_flat_finger), the second finger's drive
    sometimes following the first's. At the zero pose both tips move up (+z), alongside: only half closed do they
    close on each other."""
    rng = random.Random(seed)
    w = Writer(rng)
    flange = w.link('<box size="0.02 0.02 0.02"/>')
    palm = w.link('<box size="0.08 0.1 0.05"/>')
    w.joint("fixed", flange, palm, (0.0, 0.0, 0.02))
    coupled = rng.random() < 0.5  # the second finger's drive follows the first's
    first, drive, curl = _flat_finger(w, rng, palm, (0.0, 0.03, 0.05), 1.0, 2)
    second, follower, other = _flat_finger(w, rng, palm, (0.0, -0.03, 0.05), -1.0, 2,
                                           follows=(drive, curl) if coupled else None)
    chains = [Chain(first, drive, "pivoting", None, "jaw"),
              Chain(second, follower, "pivoting", first[0] if coupled else None, "jaw")]
    tool_links = {palm}.union(*(c.links for c in chains))
    leaves = sorted(c.links[-1] for c in chains)
    return Built(w.urdf(), "flat", "ParallelGripper", flange, palm, tool_links, leaves, chains, flange,
                 f"flat two-finger gripper, curls {[curl, other]}, coupled {coupled}")


def build_flat_gripper(seed: int) -> Built:
    """A three-finger gripper written flat, as the BarrettHand is: fingers laid out from the palm (+y for a pair
    side by side at -/+x, -y for the one facing them), each curling up and in by two or three joints (_flat_finger);
    each of the pair first turns on a spread joint about the palm's axis (z), the third hangs on a knuckle fixed to
    the palm. At the zero pose every tip moves up (+z), the pair's spread joints move their tips towards each other:
    only half closed do the fingers close on one another."""
    rng = random.Random(seed)
    w = Writer(rng)
    box = '<box size="0.02 0.02 0.02"/>'
    flange = w.link(box)
    palm = w.link('<cylinder radius="0.045" length="0.08"/>')
    w.joint("fixed", flange, palm, (0.0, 0.0, 0.02))
    spread = rng.choice([(0.0, math.pi), (-0.6, 0.6)])
    height, offset = rng.uniform(0.03, 0.05), rng.uniform(0.03, 0.05)
    chains, tool_links = [], {palm}
    for side in (1.0, -1.0):
        base = w.link(box)
        axis = (0.0, 0.0, side * rng.choice([1.0, -1.0]))
        turn = w.joint("revolute", palm, base, (side * rng.uniform(0.02, 0.03), 0.0, height), axis, spread)
        links, _, _ = _flat_finger(w, rng, base, (0.0, offset, 0.0), 1.0, 2)
        chains.append(Chain([base, *links], turn, "pivoting", None, "finger"))
    knuckle = w.link(box)
    w.joint("fixed", palm, knuckle, (0.0, 0.0, height))
    tool_links.add(knuckle)
    links, drive, _ = _flat_finger(w, rng, knuckle, (0.0, -offset, 0.0), -1.0, rng.randint(2, 3))
    chains.append(Chain(links, drive, "pivoting", None, "thumb"))
    for c in chains:
        tool_links.update(c.links)
    leaves = sorted(c.links[-1] for c in chains)
    return Built(w.urdf(), "flat", "MultiFingerGripper", flange, palm, tool_links, leaves, chains, flange,
                 f"flat three-finger gripper, spread {spread}", chains[-1].name)
