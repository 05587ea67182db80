"""What the robot's shape settles before any question: its hands and grippers (their leaves and mounts), the
feet it stands on, the leaves along a limb rather than at its end, where no end effector is, and the limbs' own
last links and the bars swinging beside a moving chain, which are no sensors (nor tools, where they roll or are
the limb's last segment).
"""
from __future__ import annotations

import math

from urdfkb.pipeline.abstraction.frames import MIRROR_EPS, drawn_alike, is_frame, mirrored, placing_joints
from urdfkb.pipeline.abstraction.structure import (FingerChain, ToolStructure, linkage_bars, moving_children,
                                                   tool_structure)
from urdfkb.pipeline.reading.tree import Edge, KinematicTree, Vector, fork_of, rotate_rpy
from urdfkb.pipeline.abstraction.vectors import dot, norm, off_axis, sub, unit

HAND_REACH = 0.3  # m: the farthest a fingertip lies from where its hand's fingers part (a limb reaches further)
HAND_TO_LEG = 0.4  # a hand's fingers reach less than this share of the legs' reach (at most 0.29 in the truth
# robots' and probes' hands; small humanoids' arms reach 0.56 to 0.82 of their legs)
MAX_FINGER_JOINTS = 5  # movable joints in one finger, thumb included
TOOL_POINT = 0.03  # m: a tool centre point lies this close to the fingertips' span across the hand, at most
TIP_DEPTH = 0.6  # and at least this share of the way out from where the fingers part to their tips (touch pads on a
# hand's back or sides lie under half of it)
FOOT_BAND = 0.05  # m: feet are the limb tips within this of the robot's lowest point at the zero pose
LEVEL_RISE = 0.25  # share of its length a sprawled leg held out level may rise above its trunk (0.15 at most seen)
LOW_SHARE = 1 / 3  # of a robot's height: wheels spin this low (0.23 at most in the files seen; grippers' spinning
# parts 0.56 and up)
STANCE = 0.15  # m: how far above its lowest points the root of a robot that stands on them lies, at the least
TRUNK_TO_LEG = 0.5  # a trunk that legs carry is at least this share of their length long from its front legs to its
# rear ones (0.9 on two public quadruped files, a small one 0.12 m long among them)
MASS_ALIKE = 0.01  # share: two parts' masses this near each other are one part's, mirrored
MIRRORED_AXIS = 0.1  # two unit axes mirror each other where each component agrees (or opposes) within this
LIMB_JOINTS = 4  # movable joints in series, nothing branching off, that make a limb (a neck's pan and tilt do not)
ROLL_OFFSET = 0.01  # m: a limb's last joint this far out from its parent's origin, along its own axis, rolls
ON_AXIS = 0.001  # m: a centre of mass this near a joint's axis lies on it (every other limb end of the truth robots,
# the parts library and the probe files lies 10 mm or more off its axis, or at its joint's origin)
FULL_TURN = 0.99 * 2 * math.pi  # rad: a joint's range at which it turns a wheel (files write -3.14..3.14)
ROLL_ALONG = 0.95  # |cosine| between that joint's axis and the line out to it above which it runs along it
SERVO_LIMB = 3  # bounded joints in one limb, each written with a full turn, that say the file gives its servos that
# range, not that the limb's last one rolls a wheel (a steered wheel has two joints)
OPEN_LOOP = 3  # free pivots about parallel axes in series, ending at a leaf, that are a closed linkage written open
PARALLEL = 0.99  # |cosine| between two joints' axes above which they are parallel
SWING_JOINTS = 2  # joints turning or sliding the link a leaf swings from beside the joint carrying its chain on (a
# sensor tilting on its own joint hangs from a trunk or a lift: fewer)
LAST_SEGMENT = 0.15  # share of its limb's length at which a limb end's centre of mass lies out from its own joint's
# axis, at the least, where it is the limb's last segment (a forearm on its elbow: 0.20, 0.22 and 0.39 in three
# public humanoids); a lone jaw's lies at most 0.04 of its arm's in the truth robots
_SWINGS = ("revolute", "continuous", "prismatic")  # a floating or planar root joint moves a whole robot, not a limb


def hand_leaves(tree: KinematicTree) -> frozenset[str]:
    """The leaves of every hand or gripper the tree's shape shows (hand_mounts)."""
    return frozenset(hand_mounts(tree, hands(tree)))


def hand_mounts(tree: KinematicTree, found: list[tuple[ToolStructure, list[str]]]) -> dict[str, str]:
    """Each leaf of the hands `found` (hands) → the hand's mount, read before anything is asked, so that they
    go to the end-effector pass and not to the sensors. A hand whose tool point lies on the flange it is bolted to,
    beside its mount (a coupling), is mounted where the two meet: one tool with its point."""
    return {leaf: fork_of(tree, [structure.mount, *leaves]) for structure, leaves in found for leaf in leaves}


def hands(tree: KinematicTree) -> list[tuple[ToolStructure, list[str]]]:
    """Every hand or gripper the tree's shape shows, with its leaves. A hand is a fork (tool_structure) with two
    finger chains or more among its hand-sized moving subtrees (at most MAX_FINGER_JOINTS joints, each with a
    range: a wheel or a caster spins freely; every link within HAND_REACH). Its leaves are those of its
    finger chains, of its other hand-sized moving subtrees (the drive of a hand that opens as a whole), of its
    fingers' linkages (a four-bar's crank beside a finger, whatever its bars' joints), and
    the pure frames fixed to its rigid body that lie out among the fingertips (_among_tips): tool centre points,
    on the hand itself or on the flange it is bolted to.
    A joint that spins (Edge.spins) is a wheel's or a caster's, never a finger's. On a robot standing on legs, the
    fingers reach less than HAND_TO_LEG of the legs' length from where they part (_leg_length)."""
    found = []
    standing = feet(tree)
    legs = _leg_length(tree, standing)
    for fork in tree.links:
        small = [c for c in moving_children(tree, fork) if _hand_sized(tree, fork, c)]
        if len(small) < 2:
            continue
        leaves = [link for c in small for link in (c, *tree.descendants(c)) if tree.is_leaf(link)]
        if standing & set(leaves):  # short legs the robot stands on, not fingers
            continue
        structure = tool_structure(tree, leaves)
        fingers = [f for f in structure.fingers if f.name in small]
        if len(fingers) < 2:
            continue
        if max(norm(tree.position_in(link, fork)) for f in fingers for link in f.links) >= HAND_TO_LEG * legs:
            continue  # a small robot's arms on its trunk, as long as its legs
        leaves += [link for c in structure.linkages if c not in small for link in (c, *tree.descendants(c))
                   if tree.is_leaf(link)]
        found.append((structure, list(dict.fromkeys([*leaves, *_tool_points(tree, structure.fork, fingers)]))))
    return found


def _leg_length(tree: KinematicTree, standing: frozenset[str]) -> float:
    """How far the legs ending at the feet `standing` reach: the distance from the link where they meet to the
    farthest foot at the zero pose, measured as a hand's fingers are (infinite where the robot stands on no legs)."""
    if not standing:
        return math.inf
    meet = fork_of(tree, sorted(standing))
    return max(norm(tree.position_in(foot, meet)) for foot in standing)


def limb_length(tree: KinematicTree, link: str, ancestor: str) -> float:
    """The sum of the joint offsets from `ancestor` down to `link`: a limb written folded is as long as stretched."""
    path = tree.chain_to_root(link)
    return sum(norm(tree.edge_to(x).origin.xyz) for x in path[:path.index(ancestor)])


def beside_hands(tree: KinematicTree, hands_found: list[tuple[ToolStructure, list[str]]]) -> frozenset[str]:
    """Bodies fixed beside one of the hands found (hands) rather than in it: leaves with geometry fixed to the body the
    hand is mounted on, not below where its fingers part (a range sensor or a camera on the wrist a gripper is
    bolted to). A pure frame there may mark the hand's tool point, and a body moving on a joint of its own there is
    the hand's (a servo horn that drives its fingers through a linkage), so neither is among them."""
    found: set[str] = set()
    for structure, leaves in hands_found:
        mount = set(rigid_body(tree, structure.mount))
        below = {structure.fork, *tree.descendants(structure.fork)}
        found.update(leaf for link in mount for leaf in tree.children(link)
                     if tree.is_leaf(leaf) and leaf not in below and leaf not in leaves and not is_frame(tree, leaf)
                     and not tree.edge_to(leaf).movable)
    return frozenset(found)


def _tool_points(tree: KinematicTree, fork: str, fingers: list[FingerChain]) -> list[str]:
    body = rigid_body(tree, fork)  # positions in its top link's frame, from the fork
    fork_at = tree.position_in(fork, body[0])

    def at(link: str) -> Vector:
        return sub(tree.position_in(link, body[0]), fork_at)
    tips = [at(max(f.links, key=lambda link: len(tree.chain_to_root(link)))) for f in fingers]
    centre = (sum(p[0] for p in tips) / len(tips), sum(p[1] for p in tips) / len(tips), sum(p[2] for p in tips) / len(tips))
    span = max(math.dist(p, centre) for p in tips)
    frames = [link for link in body if link != fork and tree.is_leaf(link) and is_frame(tree, link)]
    return [link for link in frames if _among_tips(at(link), centre, span)]


def _among_tips(point: Vector, centre: Vector, span: float) -> bool:
    """A point of the hand's body lies out among its fingertips: at least TIP_DEPTH of the way from the fork to
    their centre, along that line, and within TOOL_POINT of their span across it."""
    reach = norm(centre)
    if reach == 0:
        return norm(point) <= span + TOOL_POINT
    along = dot(point, centre) / reach
    across = math.sqrt(max(dot(point, point) - along * along, 0.0))
    return along >= TIP_DEPTH * reach and across <= span + TOOL_POINT


def _hand_sized(tree: KinematicTree, fork: str, child: str) -> bool:
    """The moving subtree `child` of `fork` could be a finger: within a hand's size (_within_hand), with no
    joint that spins (a wheel's, a caster's) but for a linkage's bars (linkage_bars), often written continuous."""
    links = (child, *tree.descendants(child))
    if not _within_hand(tree, fork, links):
        return False
    spinning = {link for link in links if tree.edge_to(link).spins}
    return not spinning or not spinning - linkage_bars(tree, links)


def _within_hand(tree: KinematicTree, fork: str, links: tuple[str, ...]) -> bool:
    """At most MAX_FINGER_JOINTS movable joints among `links` but for the bars of a linkage among them
    (linkage_bars), each link within HAND_REACH of `fork`."""
    if not all(norm(tree.position_in(link, fork)) <= HAND_REACH for link in links):
        return False
    moving = {link for link in links if tree.edge_to(link).movable}
    return len(moving) <= MAX_FINGER_JOINTS or len(moving - linkage_bars(tree, links)) <= MAX_FINGER_JOINTS


def rigid_body(tree: KinematicTree, link: str) -> tuple[str, ...]:
    """The links fixed rigidly to `link`: up through fixed joints to the first link a movable joint moves (or
    the root), and every link fixed below that one."""
    top = link
    while (parent := tree.parent(top)) is not None and not tree.edge_to(top).movable:
        top = parent
    return palm(tree, top)


def palm(tree: KinematicTree, fork: str) -> tuple[str, ...]:
    """A hand's own body: its fork and the links bolted below it (not the wrist above, whose camera is no hand's);
    of any link, the link and what is fixed below it."""
    body, stack = [], [fork]
    while stack:
        body.append(current := stack.pop())
        stack.extend(c for c in tree.children(current) if not tree.edge_to(c).movable)
    return tuple(body)


def limb_goes_on(tree: KinematicTree, leaf: str) -> bool:
    """A limb goes on from the body the leaf is fixed to: a moving subtree of that body has more movable joints
    than a hand's finger (MAX_FINGER_JOINTS) or reaches beyond HAND_REACH. The leaf sits along a limb or on the
    trunk it leaves from, not at a limb's end, where an end effector is."""
    return any(tree.edge_to(child).movable and not _within_hand(tree, link, (child, *tree.descendants(child)))
               for link in rigid_body(tree, leaf) for child in tree.children(link))


def on_feet(tree: KinematicTree, standing: frozenset[str]) -> frozenset[str]:
    """Leaves fixed to the rigid body of a foot the robot stands on (`standing`, feet): a sole's, a toe's or an
    ankle's frame, or a cleat; a foot carries no tool."""
    bodies = {link for foot in standing for link in rigid_body(tree, foot)}
    return frozenset(leaf for leaf in tree.leaves() if leaf in bodies) - standing


def off_limb_ends(tree: KinematicTree, found: list[tuple[ToolStructure, list[str]]]) -> frozenset[str]:
    """Leaves at no limb's end, so never an end effector: where a limb goes on from their body (limb_goes_on),
    or bodies beside one of the hands `found` (beside_hands)."""
    return beside_hands(tree, found) | {leaf for leaf in tree.leaves() if limb_goes_on(tree, leaf)}


def limb_ends(tree: KinematicTree) -> frozenset[str]:
    """Leaves that move on a joint of their own at the end of a limb: LIMB_JOINTS movable joints or more in series
    above them, nothing branching off up to the first link that carries more than one child (or the root), or two
    or more where the leaf's revolute joint turns through more than half a turn and its mass lies off that joint's
    axis (_off_its_axis: a small servo robot's forearm at its elbow; a drone's camera at the end of its gimbal,
    pitching 4.1 rad, is balanced on it). Such a leaf is the limb's own last link (a bare arm's flange, a foot), a jaw that
    closes against it or a finger, never a sensor, which is fixed to what it measures from (a lidar's spinning head
    or a bumper on its own hinge is moved by one joint, not by a limb; a camera on a pan and tilt tilts over a
    bounded arc). A joint whose limits give it no range does not move it, unless no joint of the file has one
    (KinematicTree.moving)."""
    ends = []
    for leaf in tree.leaves():
        if tree.parent(leaf) is None:  # a robot of one link
            continue
        edge = tree.edge_to(leaf)
        if not tree.moving(edge):
            continue
        path = _limb_path(tree, leaf)
        joints = _movable_between(tree, leaf, path[-1])
        if joints >= LIMB_JOINTS or (joints >= 2 and edge.joint_type == "revolute" and _past_half_turn(edge)
                                     and _off_its_axis(tree, leaf, path)):
            ends.append(leaf)
    return frozenset(ends)


def _off_its_axis(tree: KinematicTree, leaf: str, path: tuple[str, ...]) -> bool:
    """The leaf's centre of mass lies LAST_SEGMENT of its limb's length (the sum of the joint offsets along `path`)
    or more out from its own joint's axis: a segment swinging on its joint, as a forearm on its elbow, not a payload
    balanced on it, as a camera on a gimbal is (a leaf with no <inertial> is neither)."""
    facts, axis = tree.evidence.get(leaf), unit(tree.edge_to(leaf).axis)
    length = limb_length(tree, leaf, path[-1])
    return facts is not None and facts.centre is not None and axis is not None and length > 0 \
        and off_axis(facts.centre, axis) >= LAST_SEGMENT * length


def last_segments(tree: KinematicTree, ends: frozenset[str]) -> frozenset[str]:
    """Of the limb ends `ends` (limb_ends) at the end of LIMB_JOINTS movable joints or more, those whose centre of
    mass lies LAST_SEGMENT of the limb's length or more out from their own joint's axis: the limb's last segment (the
    forearm of an arm that ends in no tool, turning at its elbow), not the jaw of a one-jaw gripper, which is small
    beside the arm that carries it. The limb's length is the sum of its joints' offsets, from the first link above
    that carries more than one child (or the root) to the leaf (an arm written folded is as long as stretched out).
    A leaf with no <inertial> says nothing."""
    found = []
    for leaf in ends:
        path = _limb_path(tree, leaf)
        if _movable_between(tree, leaf, path[-1]) < LIMB_JOINTS:
            continue  # a bar or a finger hung on a branching link: no limb to measure by
        if _off_its_axis(tree, leaf, path):
            found.append(leaf)
    return frozenset(found)


def _limb_path(tree: KinematicTree, leaf: str) -> tuple[str, ...]:
    """The links from `leaf` up to the first that carries more than one child (or the root), both included."""
    path = tree.chain_to_root(leaf)
    for i, link in enumerate(path[1:], start=1):
        if len(tree.children(link)) > 1:
            return path[:i + 1]
    return path


def swinging_leaves(tree: KinematicTree) -> frozenset[str]:
    """Leaves that swing on a joint of their own beside the joint that carries a moving chain on: the joint moves
    them through a range (it neither spins, as a wheel or a lidar's head, nor is its range empty), the link they
    hang from carries the chain on through another joint with movable joints beyond it, and SWING_JOINTS joints or
    more turn or slide that link, its own among them. A parallelogram arm's bars written as branches beside the arm
    they follow; never a sensor, which is fixed to what it measures from or, tilting on its own joint, hangs from a
    trunk or a lift (a tilting lidar, a bumper on its hinge) or ends a chain (a camera on a pan and tilt)."""
    def goes_on(child: str) -> bool:
        return tree.edge_to(child).movable and any(tree.edge_to(d).movable for d in tree.descendants(child))

    swinging = []
    for leaf in tree.leaves():
        edge = tree.edge_to(leaf)
        if not tree.moving(edge) or edge.spins:
            continue
        moved = sum(tree.edge_to(link).joint_type in _SWINGS for link in tree.chain_to_root(edge.parent)[:-1])
        if moved >= SWING_JOINTS and any(goes_on(c) for c in tree.children(edge.parent) if c != leaf):
            swinging.append(leaf)
    return frozenset(swinging)


def jaw_pairs(tree: KinematicTree) -> frozenset[str]:
    """Two leaves, the only children of a link that a joint or more moves, each moved on a bounded joint of its own
    (one that neither spins nor is held at zero), drawn alike and hung as mirror images of each other across one of
    that link's planes, their joints' axes mirrored with them: they move as mirror images, as a gripper's two jaws do
    (written with no <inertial>, nothing tells which way they close); or hinged on one pin (_on_one_pin: scissor
    jaws). Jaws, never sensors, which are fixed to what they measure from."""
    found: set[str] = set()
    for body in tree.links:
        pair = tree.children(body)
        if len(pair) != 2 or not all(tree.is_leaf(x) for x in pair) or _movable_above(tree, body) == 0:
            continue
        a, b = pair
        edges = [tree.edge_to(x) for x in pair]
        if not all(tree.moving(e) and not e.spins and e.joint_type in ("revolute", "prismatic") for e in edges) \
                or edges[0].joint_type != edges[1].joint_type:
            continue
        if _on_one_pin(tree, body, a, b):
            found.update(pair)
            continue
        if not drawn_alike(tree, a, b):
            continue
        pa, pb = tree.position_in(a, body), tree.position_in(b, body)
        ua, ub = (unit(tree.direction_in(x, body, e.axis)) for x, e in zip(pair, edges))
        if ua is None or ub is None:
            continue
        polar = edges[0].joint_type == "prismatic"  # a slide's axis mirrors as a point does, a hinge's as its normal
        for axis in range(3):
            if abs(pa[axis] - pb[axis]) > MIRROR_EPS and mirrored(pa, pb, axis) \
                    and all(abs(ua[k] + ub[k] if (k == axis) == polar else ua[k] - ub[k]) <= MIRRORED_AXIS for k in range(3)):
                found.update(pair)
    return frozenset(found)


def _on_one_pin(tree: KinematicTree, body: str, a: str, b: str) -> bool:
    """Leaves `a` and `b` of `body` turn on revolute joints hinged at one point about one line (origins within
    MIRROR_EPS, axes parallel or opposed), of one mass (within MASS_ALIKE of each other), their centres of mass at one
    distance from that line (within MIRROR_EPS) and more than MIRROR_EPS apart: two jaws on one pin closing like
    scissors (a Katana's), whatever meshes draw the left and the right one."""
    ea, eb = tree.edge_to(a), tree.edge_to(b)
    fa, fb = tree.evidence.get(a), tree.evidence.get(b)
    if ea.joint_type != "revolute" or fa is None or fb is None:
        return False
    mass_a, mass_b, centre_a, centre_b = fa.mass, fb.mass, fa.centre, fb.centre
    if mass_a is None or mass_b is None or centre_a is None or centre_b is None \
            or abs(mass_a - mass_b) > MASS_ALIKE * max(mass_a, mass_b):
        return False
    pin = tree.position_in(a, body)
    ua, ub = unit(tree.direction_in(a, body, ea.axis)), unit(tree.direction_in(b, body, eb.axis))
    if ua is None or ub is None or math.dist(pin, tree.position_in(b, body)) > MIRROR_EPS \
            or abs(abs(dot(ua, ub)) - 1.0) > MIRRORED_AXIS:
        return False
    centres = [tree.position_in(a, body, centre_a), tree.position_in(b, body, centre_b)]
    out = [off_axis(sub(c, pin), ua) for c in centres]  # each centre's distance from the pin's line
    return abs(out[0] - out[1]) <= MIRROR_EPS and math.dist(*centres) > MIRROR_EPS


def frozen_fingertips(tree: KinematicTree) -> frozenset[str]:
    """The tips of a hand written with every finger joint fixed: three chains or more (_fixed_chains) from one body
    at a limb's end (LIMB_JOINTS movable joints or more above it), and the jaws of a gripper so written
    (frozen_jaws). Fingers, never sensors (a stack of standoffs on a mobile base has the shape, but no limb carries
    it)."""
    tips: set[str] = set()
    for body in tree.links:
        if _movable_above(tree, body) >= LIMB_JOINTS and len(ends := _fixed_chains(tree, body)) >= 3:
            tips.update(ends)
    return frozenset(tips) | frozen_jaws(tree)


def frozen_jaws(tree: KinematicTree) -> frozenset[str]:
    """The jaws of a gripper written with every joint fixed: on a body at the end of a limb (LIMB_JOINTS movable
    joints or more from it up to the limb's top, limb_top, and none below it), exactly two fixed chains
    (_fixed_chains) whose tips are mirror images of each other across a plane of the body; with them the body's
    other leaves with geometry fixed to it that are mirror images of each other (a jaw's second bar, an inner
    knuckle). Two cameras on a head carried with the arms, sensors beside a gripper that moves, or bumpers half way
    along an arm are on no such body."""
    tips: list[str] = []
    for body in tree.links:
        ends = _fixed_chains(tree, body)  # the cheap test first: most links carry no two such chains
        if len(ends) == 2 and _mirror_images(tree, body, *ends) \
                and not any(tree.edge_to(x).movable for x in tree.descendants(body)) \
                and _movable_between(tree, body, limb_top(tree, body)) >= LIMB_JOINTS:
            pieces = [c for c in tree.children(body) if c not in ends and tree.is_leaf(c) and not is_frame(tree, c)]
            tips += ends + [p for p in pieces if any(q != p and _mirror_images(tree, body, p, q) for q in pieces)]
    return frozenset(tips)


def _fixed_chains(tree: KinematicTree, body: str) -> list[str]:
    """The tips of the chains of two links or more with geometry fixed in series (one child each) from `body`, each
    within HAND_REACH of it."""
    ends = []
    for child in tree.children(body):
        path = [child]
        while not tree.edge_to(path[-1]).movable and len(below := tree.children(path[-1])) == 1:
            path.append(below[0])
        if tree.is_leaf(path[-1]) and not any(tree.edge_to(link).movable for link in path) \
                and sum(not is_frame(tree, link) for link in path) >= 2 \
                and norm(tree.position_in(path[-1], body)) <= HAND_REACH:
            ends.append(path[-1])
    return ends


def _mirror_images(tree: KinematicTree, body: str, a: str, b: str) -> bool:
    """Links `a` and `b` are mirror images of each other across a plane of `body` (one of its axes' planes):
    further than MIRROR_EPS apart across it and within MIRROR_EPS of each other along it."""
    pa, pb = tree.position_in(a, body), tree.position_in(b, body)
    return any(abs(pa[axis] - pb[axis]) > MIRROR_EPS and mirrored(pa, pb, axis) for axis in range(3))


def limb_top(tree: KinematicTree, link: str) -> str:
    """The link a limb ending at `link` starts below: the first link above it that carries another moving chain
    (static frames hung along the limb do not end it), or the root."""
    path = tree.chain_to_root(link)

    def moves(x: str) -> bool:
        return any(tree.edge_to(y).movable for y in (x, *tree.descendants(x)))
    return next((above for i, above in enumerate(path[1:], start=1)
                 if any(moves(c) for c in tree.children(above) if c != path[i - 1])), path[-1])


def rolling(tree: KinematicTree, leaf: str) -> bool:
    """The leaf's joint turns through more than half a turn (or spins), or turns about the line from its parent's
    origin out to it (ROLL_OFFSET or more along its own axis: a wrist roll, the limb running along that axis), or
    about an axis through the leaf's own centre of mass (_about_itself), whatever its range: a limb end so moved is
    a flange that rolls or a wheel, not a jaw or a finger, which close over a bounded arc (under 2.5 rad in the
    hands, grippers and arms of the truth robots and the parts library) about a hinge across the line they hang
    out along, their mass swinging off it. A leaf ending a free linkage (_free_linkage) does not spin for that, and
    a range its file gives every joint of the leaf's limb says nothing of it (_servo_range)."""
    edge = tree.edge_to(leaf)
    if edge.spins and not _free_linkage(tree, leaf):
        return True
    if edge.joint_type not in ("revolute", "continuous"):
        return False
    if (_past_half_turn(edge) and not _servo_range(tree, leaf)) or _about_itself(tree, leaf):
        return True
    out, axis = edge.origin.xyz, unit(rotate_rpy(edge.origin.rpy, edge.axis))
    return axis is not None and norm(out) >= ROLL_OFFSET and abs(dot(axis, out)) > ROLL_ALONG * norm(out)


def _free_linkage(tree: KinematicTree, leaf: str) -> bool:
    """The leaf ends OPEN_LOOP joints or more in series that spin (Edge.spins) about parallel axes: the bars of a
    closed linkage (a gripper's finger loop, its joints left free for the loop to hold), which a URDF tree writes
    open; no wheel turns on a hub that spins about the wheel's own axis."""
    path = tree.chain_to_root(leaf)
    if len(path) <= OPEN_LOOP:
        return False
    above = path[OPEN_LOOP]
    axes = []
    for link in path[:OPEN_LOOP]:
        edge = tree.edge_to(link)
        if not edge.spins or (axis := unit(tree.direction_in(link, above, edge.axis))) is None:
            return False
        axes.append(axis)
    return all(abs(dot(axes[0], axis)) > PARALLEL for axis in axes[1:])


def _about_itself(tree: KinematicTree, leaf: str) -> bool:
    """The leaf's centre of mass lies on its joint's axis (within ON_AXIS) and is placed off the joint's origin
    (ON_AXIS or more along it): the link turns about itself, as a flange on a wrist roll whose origin the file sets
    beside the line of the arm. A centre of mass written at the origin itself says nothing (files leave it there)."""
    facts, axis = tree.evidence.get(leaf), unit(tree.edge_to(leaf).axis)
    if facts is None or facts.centre is None or axis is None:
        return False
    return off_axis(facts.centre, axis) < ON_AXIS <= norm(facts.centre)


def _turns_fully(edge: Edge) -> bool:
    """The joint spins, or its limits give it a full turn or more (FULL_TURN): a wheel the file writes revolute.
    A servo's range, up to 300 degrees on the hobby servos small legged robots are built of, rolls no wheel."""
    return edge.spins or edge.limits is not None and edge.limits[1] - edge.limits[0] >= FULL_TURN


def _servo_range(tree: KinematicTree, leaf: str) -> bool:
    """SERVO_LIMB movable joints or more above the leaf's, and every movable joint from it up to the root, bounded
    and written with one range: the file gives each servo that range (a small humanoid's, 240 degrees each), which
    says nothing of what its last one moves, where that is no segment of the limb swinging on it (_off_its_axis: a
    forearm on its elbow): a jaw closing on the forearm, or a flange."""
    edges = [tree.edge_to(link) for link in tree.chain_to_root(leaf)[:-1]]
    movable = [e for e in edges if e.movable]
    return len(movable) > SERVO_LIMB and all(e.limits == movable[0].limits and not e.spins for e in movable) \
        and not _off_its_axis(tree, leaf, _limb_path(tree, leaf))


def _past_half_turn(edge: Edge) -> bool:
    """The joint's limits give it a range of more than half a turn."""
    return edge.limits is not None and edge.limits[1] - edge.limits[0] > math.pi


def spinning_low(tree: KinematicTree) -> frozenset[str]:
    """Leaves that spin on their own joint (Edge.spins) in the lowest LOW_SHARE of the robot's height at the zero
    pose, two or more of them: wheels, wherever they hang (a rover's on steering joints and bogies, a caster's under
    its swivel); never a tool, whose jaws close over a bounded arc at a limb's end (the spinning drive screw or prop
    of a gripper an arm carries rides half to all of the robot's height up in the files seen; the shape step leaves
    out a hand's leaves, as a hand published on its own lies at the bottom of its file)."""
    heights = {link: tree.position_in(link, tree.root)[2] for link in tree.links if link != tree.root}
    if not heights:
        return frozenset()
    low, span = min(heights.values()), max(heights.values()) - min(heights.values())
    spinning = [leaf for leaf in tree.leaves() if leaf in heights and tree.edge_to(leaf).spins
                and heights[leaf] - low <= LOW_SHARE * span]
    return frozenset(spinning) if len(spinning) >= 2 else frozenset()


def spinning_on_trunk(tree: KinematicTree) -> frozenset[str]:
    """Leaves that spin on their own joint (continuous, or revolute with no range given) from the trunk (on_trunk),
    two or more of them: wheels, rotors, propellers, thrusters; never a tool, whose jaws and fingers close over a
    bounded arc at a limb's end (a gripper's own spinning drive screw hangs below the arm's joints). A lone spinner
    (a spindle, a mower's blade) is left to the model."""
    placing = placing_joints(tree)
    spinning = [leaf for leaf in tree.leaves() if tree.parent(leaf) is not None and tree.edge_to(leaf).spins
                and on_trunk(tree, tree.edge_to(leaf).parent, placing)]
    return frozenset(spinning) if len(spinning) >= 2 else frozenset()


def on_trunk(tree: KinematicTree, link: str, placing: frozenset[str]) -> bool:
    """No joint that turns or slides lies between the root and `link` but those placing the whole robot
    (frames.placing_joints): the link is part of the trunk."""
    return not any(tree.edge_to(x).joint_type in _SWINGS and tree.edge_to(x).joint not in placing
                   for x in tree.chain_to_root(link)[:-1])


def feet(tree: KinematicTree) -> frozenset[str]:
    """The leaves a robot stands on: tips of limbs (two movable joints or more above them) within FOOT_BAND
    of the robot's lowest link origin at the zero pose (the trunk and the frames above it aside), reached from the
    trunk by legs (_from_trunk_by_legs) that part where they all meet, STANCE or more above them, with two movable
    joints or more each (the jaws of an underwater vehicle's gripper, hanging lowest, part with one each; a free
    flyer's gripper, hanging lowest on its arm, parts a few centimetres above its fingertips), on a robot whose trunk
    (_trunk) lies STANCE above that point where its limbs leave it (_leaving_height) and that has two such tips at
    least. Where a limb ends there is a foot, not a tool; a wheel (_rolls: a caster's wheel on its swivel) rolls and
    is none. A robot whose zero pose holds its legs out level with its trunk stands on none that way: its feet are
    those of its sprawled legs (_sprawled_feet)."""
    height = {link: tree.position_in(link, tree.root)[2] for link in tree.links}
    placing = placing_joints(tree)
    top = _trunk(tree, placing)
    run = set(tree.chain_to_root(top))  # the trunk and the frames above it: a file may put its root on the floor
    lowest = min((z for link, z in height.items() if link not in run), default=height[top])
    if _leaving_height(tree, top, height) - lowest < STANCE:
        return _sprawled_feet(tree, top, placing)
    low = [leaf for leaf in tree.leaves() if height[leaf] <= lowest + FOOT_BAND and _movable_above(tree, leaf) >= 2
           and not _rolls(tree, leaf)]
    limbs = [leaf for leaf in low if _from_trunk_by_legs(tree, leaf, set(low), placing)]
    if len(limbs) < 2:
        return frozenset()
    meet = fork_of(tree, limbs)  # legs part there, STANCE above the feet, each with two joints or more of its own
    if _leaving_height(tree, meet, height) - lowest < STANCE:
        return frozenset()
    legs = [leaf for leaf in limbs if _movable_between(tree, leaf, meet) >= 2]
    return frozenset(legs) if len(legs) >= 2 else frozenset()


def _leaving_height(tree: KinematicTree, link: str, height: dict[str, float]) -> float:
    """How high the limbs leave `link`: the highest of its origin and its moving children's joints (an exported
    file may put a pelvis's origin on the floor, its hips where they are)."""
    return max([height[link], *(height[c] for c in tree.children(link) if tree.edge_to(c).movable)])


def _trunk(tree: KinematicTree, placing: frozenset[str]) -> str:
    """The link a robot's limbs hang from: below the joints placing it (frames.placing_joints), or the link that
    the run of bare frames from the root (frames.is_frame, each the parent of one link by a fixed joint: a `world`
    or footprint frame) ends at."""
    if placing:
        return max((e.child for e in tree.edges if e.joint in placing), key=lambda x: len(tree.chain_to_root(x)))
    link = tree.root
    while is_frame(tree, link) and len(kids := tree.children(link)) == 1 and not tree.edge_to(kids[0]).movable:
        link = kids[0]
    return link


def _rolls(tree: KinematicTree, leaf: str) -> bool:
    """The leaf is a wheel: it spins on its own joint as a wheel's body does (wheel_body: a caster's wheel on its
    swivel). A frame fixed on a wheel's tyre (a ground-contact point) may still be a foot: a wheel-legged robot's
    legs end there."""
    return tree.edge_to(leaf).movable and wheel_body(tree, leaf)


def _sprawled_feet(tree: KinematicTree, trunk: str, placing: frozenset[str]) -> frozenset[str]:
    """The tips of four limbs or more leaving the trunk as legs do (_from_trunk_by_legs), no higher than the trunk
    (FOOT_BAND, or LEVEL_RISE of the limb's length: actuators stacked at its hips lift it), with two joints or more
    that move (KinematicTree.moving: a wheel's joint written 0..0 where the file ranges others moves nothing), each
    carrying no wheel
    (wheel_body, or a leaf turning a full turn: `_turns_fully`, unless SERVO_LIMB joints or more of the limb, every
    one bounded, are all written with a full turn: a servo robot's file gives each servo that range), as many joints
    in each, that leave it in mirrored pairs (each one's attachment point mirrored across the trunk's x-z plane,
    REP 103's left and right, lies within MIRROR_EPS of another's) spread from front to back TRUNK_TO_LEG of the
    longest one's length or more (a limb's length is the sum of its joints' offsets: a leg written folded is as long
    as stretched out): a quadruped's or hexapod's legs, whatever its zero pose or size. A hand's fingers leave its
    palm in a row, its thumb unpaired."""
    top = tree.position_in(trunk, tree.root)[2]
    tips = [leaf for leaf in tree.leaves() if trunk in tree.chain_to_root(leaf)[1:]  # a leg comes down, or out level
            and tree.position_in(leaf, tree.root)[2] - top <= max(FOOT_BAND, LEVEL_RISE * limb_length(tree, leaf, trunk))]
    limbs: dict[str, tuple[str, float]] = {}  # the limb's first moving link -> its tip, its length
    for tip in tips:
        path = tree.chain_to_root(tip)
        moving = [x for x in path[:path.index(trunk)] if tree.moving(tree.edge_to(x))]
        if len(moving) < 2 or not _from_trunk_by_legs(tree, tip, set(tips), placing):
            continue
        first = moving[-1]
        servos = len(moving) >= SERVO_LIMB and all(_turns_fully(tree.edge_to(x)) and not tree.edge_to(x).spins
                                                  for x in moving)
        if any(wheel_body(tree, x) or tree.is_leaf(x) and _turns_fully(tree.edge_to(x)) and not servos
               for x in (first, *tree.descendants(first))):
            continue  # a wheel anywhere on it: a wheel module
        length = limb_length(tree, tip, first)
        if length > limbs.get(first, ("", 0.0))[1]:  # one tip per limb: the farthest out
            limbs[first] = (tip, length)
    by_count: dict[int, list[str]] = {}
    for first, (tip, _) in limbs.items():
        by_count.setdefault(_movable_between(tree, tip, tree.edge_to(first).parent), []).append(first)
    for firsts in by_count.values():
        at = [tree.position_in(first, trunk) for first in firsts]
        mirrored = all(any(i != j and math.dist((a[0], -a[1], a[2]), b) <= MIRROR_EPS for j, b in enumerate(at))
                       for i, a in enumerate(at))
        spread = max(a[0] for a in at) - min(a[0] for a in at)
        if len(firsts) >= 4 and mirrored and spread >= TRUNK_TO_LEG * max(limbs[first][1] for first in firsts):
            return frozenset(limbs[first][0] for first in firsts)
    return frozenset()


def wheel_body(tree: KinematicTree, link: str) -> bool:
    """The link spins on its joint (Edge.spins) with no movable joint below it and every frame of its rigid body
    (its fixed descendants' origins) within ROLL_OFFSET of that joint's axis, or of the rim of a cylinder of the body
    drawn around the axis, beside it along the axis (_tread): a wheel, a roller or a rotor, a contact frame on its
    tyre. A leg's last segment written continuous (servo legs' files leave the limits out) carries its foot's
    frame, or the screws of a shank drawn as a mesh, out from the knee, or is drawn as a primitive shape centred
    out from it (_drawn_off_axis); its upper joints carry joints on. A shank drawn as a mesh with no frame below it
    says nothing, and stays a wheel."""
    edge, below = tree.edge_to(link), tree.descendants(link)
    axis = unit(edge.axis)
    if not edge.spins or axis is None or any(tree.edge_to(x).movable for x in below):
        return False
    if any(_drawn_off_axis(tree, link, x, axis) for x in (link, *below)):
        return False
    treads = [tread for x in (link, *below) if (tread := _tread(tree, link, x, axis)) is not None]
    return all(_on_wheel(tree.position_in(x, link), axis, treads) for x in below)


def _drawn_off_axis(tree: KinematicTree, link: str, x: str, axis: Vector) -> bool:
    """`x` of the rigid body of spinning `link` is drawn as a primitive shape alone (no mesh), centred farther than
    ROLL_OFFSET from the axis: a body swung about its joint, as a limb's segment is; a wheel, a roller or a rotor is
    drawn round its axis."""
    facts = tree.evidence.get(x)
    if facts is None or facts.meshes or facts.drawn_at is None:
        return False
    return off_axis(tree.position_in(x, link, facts.drawn_at), axis) > ROLL_OFFSET


def _tread(tree: KinematicTree, link: str, x: str, axis: Vector) -> tuple[float, float, float] | None:
    """Where `x` of the rigid body of spinning `link` is drawn as a cylinder whose origin lies on the axis (within
    ROLL_OFFSET): its position along the axis, its radius and its half length."""
    facts = tree.evidence.get(x)
    cylinder = facts.cylinder if facts is not None else None
    at = tree.position_in(x, link)
    if cylinder is None or off_axis(at, axis) > ROLL_OFFSET:
        return None
    return dot(at, axis), cylinder[0], cylinder[1] / 2


def _on_wheel(point: Vector, axis: Vector, treads: list[tuple[float, float, float]]) -> bool:
    """The point lies within ROLL_OFFSET of the axis, or of the rim of a tread beside it along the axis."""
    out, along = off_axis(point, axis), dot(point, axis)
    return out <= ROLL_OFFSET or any(out <= ROLL_OFFSET + radius and abs(along - centre) <= half + ROLL_OFFSET
                                     for centre, radius, half in treads)


def _movable_between(tree: KinematicTree, link: str, ancestor: str) -> int:
    """Movable joints on the path up from `link` to `ancestor`."""
    path = tree.chain_to_root(link)
    return sum(tree.edge_to(x).movable for x in path[:path.index(ancestor)])


def _from_trunk_by_legs(tree: KinematicTree, tip: str, tips: set[str], placing: frozenset[str]) -> bool:
    """Between the trunk (on_trunk) and `tip`, no link where limbs to two of `tips` or more part carries a moving
    subtree that ends at none of them: the limb leaves the trunk, or a pelvis carrying only legs, as a leg does (its
    own bars, toes and springs aside). The fingertips of an upper body's hands hanging lowest pass a torso that
    carries a head beside the arms: no feet."""
    path = tree.chain_to_root(tip)
    for link in path[1:]:
        if on_trunk(tree, link, placing):
            return True  # the trunk: limbs leave it
        ends_at_tip = {c: bool(tips & {c, *tree.descendants(c)}) for c in tree.children(link)}
        if sum(ends_at_tip.values()) < 2:
            continue  # along one limb: its own bars, toes and springs
        if any(c not in path and tree.edge_to(c).movable and not ends for c, ends in ends_at_tip.items()):
            return False
    return True


def _movable_above(tree: KinematicTree, link: str) -> int:
    """Movable joints between the tree's root and `link`, its own included."""
    return sum(tree.edge_to(x).movable for x in tree.chain_to_root(link)[:-1])
