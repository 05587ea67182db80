"""Generated grippers and hands (tests/hand_robots.py): structure finds every finger chain, its links,
drive, oppositions and mount; the reasoner infers the kind the ontology's definitions give.

Structure only over hundreds of seeds (no model, no reasoner): settle is called as the pipeline
calls it, on the tool's leaves as identified, grouped under a mount the model might have chosen.
"""
from __future__ import annotations

import random

import pytest
from tests.hand_robots import Built, build, build_flat_gripper, build_flat_pair, build_open_hand
from tests.urdf_writer import Writer

from urdfkb.pipeline.reading.ingest import load_urdf
from urdfkb.pipeline.knowledge.reasoning import classify
from urdfkb.pipeline.abstraction.stages.attachment import sub_chain
from urdfkb.pipeline.abstraction.stages.grouping import Group
from urdfkb.pipeline.abstraction.stages.tools import settle
from urdfkb.pipeline.abstraction.hands import hands
from urdfkb.pipeline.abstraction.structure import ToolStructure, linkage_bars, tool_structure

SEEDS = range(400)
REASONED = list(range(0, 400, 25))  # one reasoner run over every layout


def settled(built: Built):
    """The pipeline's settle on the tool's leaves, in one group (grouping merges chains that meet inside
    one of them) under a mount the model might have picked (the true mount or higher up the arm)."""
    tree = load_urdf(built.urdf)
    rng = random.Random(len(built.urdf))
    above = tree.chain_to_root(built.fork)
    root = rng.choice((above[1:4] if built.fork != built.mount else above[1:3]) or above[-1:])
    groups = [Group([sub_chain(tree, leaf, root) for leaf in built.leaves])]
    notes: list[str] = []
    result = settle(tree, groups, lambda leaf: leaf in built.leaves, notes.append)
    return tree, result, notes


def problems(built: Built) -> list[str]:
    """What structure got wrong on this robot (empty: all right)."""
    tree, result, notes = settled(built)
    if len(result) != 1:
        return [f"{len(result)} tools: {notes}"]
    group, s = result[0]
    found = []
    roots = {c.root for c in group.chains}
    if roots != {built.mount} or s.mount != built.mount:
        found.append(f"mount {roots} / {s.mount}, truth {built.mount}")
    if set(group.members) != built.links:
        found.append(f"links: missing {built.links - set(group.members)}, extra {set(group.members) - built.links}")
    fingers = {f.name: f for f in s.fingers}
    truth = {c.name: c for c in built.chains}
    if set(fingers) != set(truth):
        found.append(f"chains: missing {set(truth) - set(fingers)}, extra {set(fingers) - set(truth)}")
    for name in set(fingers) & set(truth):
        f, c = fingers[name], truth[name]
        if set(f.links) != set(c.links) or f.drive != c.drive or f.motion != c.motion or f.mimics != c.mimics:
            found.append(f"chain {name}: {f.links} {f.drive} {f.motion} mimics {f.mimics}; "
                         f"truth {c.links} {c.drive} {c.motion} mimics {c.mimics}")
    found += _relations(built, s)
    return found


def _relations(built: Built, s: ToolStructure) -> list[str]:
    """The oppositions and side-by-side motions the ontology's definitions need."""
    f = {x.name: x for x in s.fingers}
    roles = {c.name: c.role for c in built.chains if c.name in f}
    found = []
    for a, role in roles.items():
        opp, along = set(f[a].opposes), set(f[a].moves_with)
        if role in ("jaw", "radial") and opp != set(roles) - {a}:
            found.append(f"{role} {a} opposes {sorted(opp)}, not every other chain")
        if role == "radial" and along:
            found.append(f"radial {a} moves with {sorted(along)}")
        if role == "finger":
            others = {b for b, r in roles.items() if r == "finger" and b != a}
            if opp & others:
                found.append(f"finger {a} opposes fingers beside it {sorted(opp & others)}")
            if not others <= along:
                found.append(f"finger {a} does not move with {sorted(others - along)}")
            if built.thumb not in opp:
                found.append(f"finger {a} does not oppose the thumb")
        if role == "thumb":
            fingers = {b for b, r in roles.items() if r == "finger"}
            if len(opp & fingers) < min(2, len(fingers)) or opp - fingers:
                found.append(f"thumb {a} opposes {sorted(opp)} of fingers {sorted(fingers)}")
    return found


@pytest.mark.parametrize("seed", SEEDS)
def test_structure_finds_every_finger_chain_and_the_mount(seed):
    built = build(seed)
    assert problems(built) == [], built.description


@pytest.mark.parametrize("seed", range(100))
def test_a_gripper_or_hand_on_its_own_is_one_tool(seed):
    """No arm carries it (the URDF's root is its flange or palm): still one tool, not split finger by
    finger as if each finger were an arm, nor dropped as a caster on a base."""
    built = build(seed, alone=True)
    assert problems(built) == [], built.description


@pytest.mark.parametrize("seed", range(60))
def test_a_fingers_linkage_written_as_a_chain_of_its_own_is_no_finger(seed):
    """Beside each finger, a four-bar's crank hung on the same link at the finger's first joint, pivoting about
    the same axis, shorter than the finger, and bars on the finger's own pins, written continuous (a URDF tree
    cannot close the loop): the crank is the finger's linkage, not a finger of its own, the bars neither end the
    finger nor count among its joints, and neither stops the hand being found."""
    built = build(seed, linkages=True)
    assert problems(built) == [], built.description
    tree, result, _ = settled(built)
    assert set(result[0][1].mechanisms) == set(built.linkages), built.description
    found = hands(tree)  # on the arm, before any question: bars aside, each finger is hand-sized
    assert found and built.moving_leaves <= set(found[0][1]), built.description


@pytest.mark.parametrize("seed", range(60))
def test_a_linkage_turning_freely_beside_its_finger_on_the_same_pin_is_no_finger(seed):
    """The same linkages, each crank and bar 1 cm beside its finger's joint along the pin and turning freely (as
    some underactuated hands' descriptions write them): still the fingers' linkages and bars. Read as fingers of
    their own, each finger's first link with its crank had looked like a gripper of its own, and the hand was lost."""
    built = build(seed, linkages=True, apart=True)
    assert problems(built) == [], built.description
    tree, result, _ = settled(built)
    assert set(result[0][1].mechanisms) == set(built.linkages), built.description
    found = hands(tree)
    assert found and built.moving_leaves <= set(found[0][1]), built.description


def test_fingers_side_by_side_on_one_shaft_stay_fingers_whatever_limits_they_write():
    """Two fingers of unequal length side by side on one shaft, beside an opposing thumb, their hinges written with a
    <limit> that gives an upper bound only (the reader keeps no range then): neither is the other's linkage, which
    only a joint turning a full turn may be beside a finger's hinge on its pin."""
    w = Writer(random.Random(3))
    palm = w.link('<box size="0.08 0.08 0.02"/>')
    fingers = []
    for y, count in ((0.02, 3), (-0.02, 2)):
        parent, xyz = palm, (0.03, y, 0.01)
        for k in range(count):
            child = w.link('<box size="0.01 0.01 0.03"/>')
            name = w.name()
            w.joints.append(f'<joint name="{name}" type="revolute"><parent link="{parent}"/><child link="{child}"/>'
                            f'<origin xyz="{xyz[0]} {xyz[1]} {xyz[2]}"/><axis xyz="0 1 0"/>'
                            '<limit upper="1.2" effort="1" velocity="1"/></joint>')
            parent, xyz = child, (0.0, 0.0, 0.03)
            if k == 0:
                fingers.append(child)
    thumb = w.link('<box size="0.01 0.01 0.04"/>')
    w.joint("revolute", palm, thumb, (-0.03, 0.0, 0.01), (0.0, 1.0, 0.0), (-1.2, 0.0))
    tip = w.link('<box size="0.01 0.01 0.03"/>')
    w.joint("revolute", thumb, tip, (0.0, 0.0, 0.04), (0.0, 1.0, 0.0), (-1.2, 0.0))
    tree = load_urdf(w.urdf())
    structure = tool_structure(tree, [leaf for leaf in tree.leaves() if palm in tree.chain_to_root(leaf)])
    assert not structure.linkages and set(fingers) <= {f.name for f in structure.fingers}


@pytest.mark.parametrize("seed", range(60))
def test_a_hand_written_open_is_found_by_its_thumb(seed):
    """Fingers curling side by side into the palm and a thumb beside it that closes on them (no fingertip moves
    towards the thumb's tip at the zero pose): the shape shows a hand, its thumb opposes every finger."""
    built = build_open_hand(seed)
    assert problems(built) == [], built.description
    found = hands(load_urdf(built.urdf))
    assert found and set(found[0][1]) == set(built.leaves), built.description


@pytest.mark.parametrize("seed", range(20))
def test_an_underactuated_hand_is_found_by_its_thumb_whatever_joint_drives_it(seed):
    """Every joint of the hand follows one tendon joint on a bare frame, directly or through the joint before it
    (<mimic> of <mimic>, as qbrobotics' SoftHand is written): the fingers and thumb move as that joint closes, so
    half closed the thumb opposes the fingers (the reasoner's test below: an anthropomorphic hand), each finger
    opposes the thumb alone or curls beside one that does, and the tendon's frame is no finger."""
    built = build_open_hand(seed, synergy=True)
    tree = load_urdf(built.urdf)
    structure = tool_structure(tree, built.leaves)
    fingers = {f.name: f for f in structure.fingers}
    assert built.thumb in fingers and len(fingers[built.thumb].opposes) >= 2, built.description
    assert all(f.opposes == (built.thumb,) or (not f.opposes and f.moves_with)
               for name, f in fingers.items() if name != built.thumb), built.description
    assert set(fingers) <= {c.name for c in built.chains}, built.description


def test_the_generator_covers_every_layout():
    builds = [build(seed) for seed in SEEDS]
    assert {b.layout for b in builds} == {"gripper", "radial", "thumbed"}
    assert {b.kind for b in builds} == {"ParallelGripper", "MultiFingerGripper", "AnthropomorphicHand"}
    assert {b.mount == b.flange for b in builds} == {True, False}


@pytest.mark.reasoner
def test_the_reasoner_infers_each_kind():
    builds = [build(seed) for seed in REASONED] + [build_open_hand(seed, synergy) for seed in range(4)
                                                    for synergy in (False, True)] \
        + [build_flat_gripper(seed) for seed in range(4)] + [build_flat_pair(seed) for seed in range(4)] \
        + [build(seed, linkages=True) for seed in range(0, 400, 50)]
    structures = [settled(b)[1][0][1] for b in builds]
    inferred, _ = classify(structures)
    assert [i.cls for i in inferred] == [b.kind for b in builds]
    for b, i in zip(builds, inferred):
        # a thumb closing against two fingers is a ThumbChain even where three chains make a gripper
        assert i.thumbs == ((b.thumb,) if b.thumb else ()), b.description


def test_a_finger_that_branches_closes_along_the_path_to_its_tip():
    """A jaw carrying a side frame (a sensor pad, a marker) beside its tip: the chain's joints are read
    on the path to its tip, not over its whole subtree."""
    w = Writer(random.Random(7))
    flange, palm = w.link(), w.link()
    w.joint("fixed", flange, palm, (0.0, 0.0, 0.02))
    chains = []
    for side in (1.0, -1.0):
        jaw, knuckle, tip, pad = w.link(), w.link(), w.link(), w.link()
        w.joint("revolute", palm, jaw, (0.0, side * 0.03, 0.05), (side, 0.0, 0.0), (-0.2, 0.6))
        w.joint("revolute", jaw, knuckle, (0.0, 0.0, 0.04), (side, 0.0, 0.0), (-0.2, 0.6))
        w.joint("fixed", knuckle, tip, (0.0, 0.0, 0.03))
        w.joint("revolute", jaw, pad, (0.0, -side * 0.01, 0.02), (0.0, 0.0, 1.0), (-0.1, 0.1))  # a side branch
        chains.append((jaw, tip, pad))
    s = tool_structure(load_urdf(w.urdf()), [leaf for _, tip, pad in chains for leaf in (tip, pad)])
    assert {f.name: f.opposes for f in s.fingers} == {chains[0][0]: (chains[1][0],), chains[1][0]: (chains[0][0],)}


@pytest.mark.parametrize("share", [1.0, 0.6])
def test_jaws_sharing_one_pin_stay_jaws_whatever_their_lengths(share):
    """Two rigid jaws pivoting on one pin (scissors), the second's tip frame at `share` of the first's distance:
    neither is the other's linkage, which only a finger jointed beyond its drive has."""
    w = Writer(random.Random(11))
    flange, palm = w.link(), w.link('<box size="0.04 0.04 0.02"/>')
    w.joint("fixed", flange, palm, (0.0, 0.0, 0.02))
    jaws = []
    for length, axis in ((0.08, (1.0, 0.0, 0.0)), (0.08 * share, (-1.0, 0.0, 0.0))):
        jaw, tip = w.link('<box size="0.01 0.01 0.06"/>'), w.link()
        w.joint("revolute", palm, jaw, (0.0, 0.0, 0.03), axis, (-0.3, 0.6))
        w.joint("fixed", jaw, tip, (0.0, 0.02 if axis[0] > 0 else -0.02, length))
        jaws.append((jaw, tip))
    tree = load_urdf(w.urdf())
    s = tool_structure(tree, [tip for _, tip in jaws])
    assert {f.name: f.opposes for f in s.fingers} == {jaws[0][0]: (jaws[1][0],), jaws[1][0]: (jaws[0][0],)}
    assert s.linkages == () and [sorted(leaves) for _, leaves in hands(tree)][0] == sorted(tip for _, tip in jaws)


def test_a_joint_written_twice_in_series_carries_the_rest_of_the_finger():
    """Each finger's drive followed, at the same place and about the same axis, by a spring joint that carries the
    rest of the finger (nothing beside it): not a bar, so the finger still ends at its tip and closes."""
    w = Writer(random.Random(12))
    flange, palm = w.link(), w.link('<box size="0.04 0.04 0.02"/>')
    w.joint("fixed", flange, palm, (0.0, 0.0, 0.02))
    tips = []
    for side in (1.0, -1.0):
        proximal, spring, distal = (w.link('<box size="0.01 0.01 0.03"/>') for _ in range(3))
        tip = w.link()
        w.joint("revolute", palm, proximal, (0.0, side * 0.02, 0.03), (side, 0.0, 0.0), (-0.8, 1.2))
        w.joint("revolute", proximal, spring, (0.0, 0.0, 0.0), (side, 0.0, 0.0), (0.0, 0.7))
        w.joint("revolute", spring, distal, (0.0, 0.0, 0.07), (side, 0.0, 0.0), (-1.2, 0.8))
        w.joint("fixed", distal, tip, (0.0, -side * 0.005, 0.04))
        tips.append((proximal, tip))
    tree = load_urdf(w.urdf())
    s = tool_structure(tree, [tip for _, tip in tips])
    assert {f.name for f in s.fingers} == {proximal for proximal, _ in tips} and s.grasps()
    assert not linkage_bars(tree, (tips[0][0], *tree.descendants(tips[0][0])))


@pytest.mark.parametrize("cups", [1, 4])
def test_a_suction_gripper_on_its_own_is_one_tool_and_a_cup_on_a_base_is_none(cups):
    """A vacuum gripper described alone (its base is the URDF's root, its cups fixed to it): nothing moves and
    nothing grasps, but every leaf of the robot is the tool's, so it is one tool. The same cups on a mobile base
    with wheels beside them are no tool: a base is no arm's end."""
    for wheels in (False, True):
        w = Writer(random.Random(cups))
        base = w.link('<cylinder radius="0.05" length="0.08"/>')
        if wheels:
            for y in (0.2, -0.2):
                w.joint("continuous", base, w.link('<cylinder radius="0.1" length="0.04"/>'), (0.0, y, 0.0), (0.0, 1.0, 0.0))
        leaves = []
        for i in range(cups):
            leaves.append(w.link('<cylinder radius="0.01" length="0.02"/>'))
            w.joint("fixed", base, leaves[-1], (0.02 * (i % 2), 0.02 * (i // 2), 0.06))
        tree = load_urdf(w.urdf())
        notes: list[str] = []
        result = settle(tree, [Group([sub_chain(tree, leaf, base) for leaf in leaves])], lambda leaf: leaf in leaves,
                        notes.append)
        assert [sorted(g.leaves) for g, _ in result] == ([] if wheels else [sorted(leaves)]), notes


@pytest.mark.parametrize("seed", range(20))
def test_a_two_finger_gripper_written_flat_is_seen_half_closed(seed):
    """Two fingers laid out flat, half a turn apart (an underactuated gripper written fully open): at the zero pose
    both tips move up, alongside, so no pair closed and the fingers were typed two arms. Half closed they close on
    each other: a parallel gripper of two jaws."""
    built = build_flat_pair(seed)
    assert problems(built) == [], built.description


@pytest.mark.parametrize("seed", range(40))
def test_a_gripper_written_flat_is_seen_half_closed(seed):
    """Three fingers laid out flat, two side by side on spread joints and one facing them: at the zero pose every
    tip moves up and the pair's spread joints bring their tips together, as a parallel gripper's jaws would; half
    closed, the pair move together and the third closes on both (a gripper of three chains)."""
    built = build_flat_gripper(seed)
    assert problems(built) == [], built.description


def _parallel_four_bars(seed: int, beside: bool = False) -> tuple[bytes, str, list[str], list[str]]:
    """An arm of six joints and on its flange a gripper of two parallel four-bars, written as some descriptions of a
    two-finger adaptive gripper write it: on each side an outer bar (the driven joint, the other side's following it
    by <mimic>) carrying a fixed finger link, and an inner bar pivoting a little further in and out in the same
    plane, following the same joint the same way, with the fingertip pad hung from it on a joint turning back. With
    `beside`, the second bar of each side pivots beside the first along their axes instead (two fingers side by side,
    both curled by one joint). The gripper's body, the bars carrying the pads (or the side-by-side fingers) and the
    outer bars."""
    rng = random.Random(seed)
    w = Writer(rng)
    link = w.link('<cylinder radius="0.08" length="0.1"/>')
    for k in range(6):
        child = w.link('<box size="0.06 0.06 0.15"/>')
        w.joint("revolute", link, child, (0.0, 0.0, 0.15), (0.0, 0.0, 1.0) if k % 2 == 0 else (0.0, 1.0, 0.0),
                (-2.0, 2.0))
        link = child
    body = w.link('<box size="0.08 0.04 0.06"/>')
    w.joint("fixed", link, body, (0.0, 0.0, 0.05))
    outer_reach, inner_reach = rng.uniform(0.025, 0.035), rng.uniform(0.055, 0.065)
    drive, inner, outer = None, [], []
    for side in (1.0, -1.0):
        bar = w.link('<box size="0.01 0.01 0.04"/>')
        joint = w.joint("revolute", body, bar, (side * 0.03, 0.0, 0.05), (0.0, -side, 0.0), (0.0, 0.8),
                        mimic=drive, multiplier=1.0)
        drive = drive or joint
        w.joint("fixed", bar, w.link('<box size="0.01 0.02 0.04"/>'), (side * 0.005, 0.0, outer_reach))
        outer.append(bar)
        second = w.link('<box size="0.01 0.01 0.05"/>')
        at = (side * 0.03, 0.02, 0.05) if beside else (side * 0.012, 0.0, 0.06)
        w.joint("revolute", body, second, at, (0.0, -side, 0.0), (0.0, 0.8), mimic=drive, multiplier=1.0)
        pad = w.link('<box size="0.01 0.02 0.03"/>')
        w.joint("revolute", second, pad, (0.0, 0.0, inner_reach), (0.0, -side, 0.0), (-0.8, 0.0), mimic=drive,
                multiplier=-1.0)
        inner.append(second)
    return w.urdf(), body, inner, outer


@pytest.mark.parametrize("seed", range(12))
def test_a_parallel_four_bar_written_as_two_chains_is_one_finger(seed):
    """Each side of the gripper is one finger: its outer bar, shorter than the inner bar that carries the pad and
    turned the same way by the same joint about a parallel pin a little apart in the plane they turn in, is that
    finger's linkage (a URDF tree cannot close the loop). Counted as four fingers, the bars made three opposing
    pairs and two 'thumbs': a hand. Bars pivoting apart along their axes are fingers side by side: still four."""
    urdf, body, inner, outer = _parallel_four_bars(seed)
    tree = load_urdf(urdf)
    structure = tool_structure(tree, [leaf for leaf in tree.leaves() if body in tree.chain_to_root(leaf)])
    assert sorted(f.name for f in structure.fingers) == sorted(inner)
    assert all(f.opposes for f in structure.fingers) and set(structure.linkages) == set(outer)
    urdf, body, inner, outer = _parallel_four_bars(seed, beside=True)
    tree = load_urdf(urdf)
    structure = tool_structure(tree, [leaf for leaf in tree.leaves() if body in tree.chain_to_root(leaf)])
    assert not structure.linkages and len(structure.fingers) == 4


@pytest.mark.reasoner
def test_the_reasoner_calls_a_gripper_of_two_parallel_four_bars_a_parallel_gripper():
    structures = []
    for seed in range(3):
        urdf, body, _, _ = _parallel_four_bars(seed)
        tree = load_urdf(urdf)
        structures.append(tool_structure(tree, [leaf for leaf in tree.leaves() if body in tree.chain_to_root(leaf)]))
    inferred, _ = classify(structures)
    assert [i.cls for i in inferred] == ["ParallelGripper"] * 3
