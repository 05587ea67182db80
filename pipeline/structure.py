"""Structural facts about a candidate tool, read from the kinematic tree alone (never from names).

- The *fork* of a tool is the lowest common ancestor of its leaves: where its fingers part.
- A *finger chain* is a subtree hung on the fork's rigid body (the fork and its fixed descendants)
  by a driven joint, its *drive*: any type but fixed, or a fixed joint a <transmission> drives,
  moving prismatic (sliding), pivoting (revolute, continuous) or frozen (written fixed, yet driven),
  whose tip (its deepest link) closes against another chain's tip.
- Two chains *oppose* when their tips move towards (or away from) each other along the line joining
  them as the tool closes, or, where the tips coincide, in opposite directions. The line is taken
  in the plane of the two motions: an offset across both (fingers of unequal length on a radial
  gripper, a thumb beside the row of fingers) neither brings the tips together nor keeps them apart.
  A chain closes by its *closing joint*: of the joints that move on their own (the drive, and any
  other joint following no <mimic>), each moving positively with the joints coupled to it by
  <mimic>, the one whose motion closes most directly on another chain's tip; a joint that only
  spreads a finger sideways or turns a thumb about its own length does not (a drive that itself
  follows another joint moves as that joint moves positively: a jaw mimicking the other with
  multiplier -1 and the same axis turns the other way). Motions are taken with every joint at zero,
  as written (open, on most hands), or, where zero lies outside some joint's range, every joint
  halfway through its range. A driven
  subtree that opposes no other, whose tip sits on its drive's axis, that hangs on a planar or
  floating joint, or whose links are all bare frames beside chains with bodies (a virtual joint the
  fingers mimic, such as a finger-distance joint), is a *mechanism* (a motor, a lead screw), not a finger.
- Two chains *move together* when their tips' closing motions are within 60 degrees
  (fingers side by side); a thumb, in the ontology, closes against fingers that move together.
- A chain *mimics* another when its drive follows (`<mimic>`) a joint of that other chain.
- The *mount* is the link the tool is bolted to: the fork's parent when the fork is rigidly fixed
  to it (a palm on a flange), else the fork itself (fingers hung straight on the arm's last moving
  link). A lone leaf is a point, pad or jaw of the body it hangs from; where nothing else moves from
  that body, the body is the tool's and the tool is mounted where the body would be (a ball's tip
  frame: where the ball is bolted; a suction tool's tip frame: where the bodies fixed in series above it, each
  carrying only the next (its cup, its body), are bolted; a one-jaw gripper's moving jaw: where its fixed jaw is; a frame
  on a link that moves on its own joint: on that link), else on the body itself (a frame on a
  torso that carries an arm).

What these facts mean (parallel gripper, thumb, hand...) is not decided here: the ontology's class
definitions do that, applied by a reasoner (pipeline.reasoning).
"""
from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TypeVar

from urdfkb.pipeline.tree import Edge, KinematicTree, Vector, rotate_rpy

OPPOSED = -0.5   # coinciding tips: cosine of their directions of motion below which they oppose
ALONGSIDE = 0.5  # cosine of two tips' directions of motion above which they move together
APPROACH = 0.4   # separate tips: share of each tip's motion along the line joining them, with opposite signs
_PLANE = 0.5     # sine of the angle between two tips' motions above which they span a plane
_TOUCHING = 1e-4  # metres: tips closer than this coincide (two jaws on one slide)
_STILL = 1e-9    # squared speed below which a tip does not move (it lies on its drive's axis)
Motion = tuple[Vector, Vector]  # a tip's position and unit direction of motion, in the fork's frame
MOTIONS = {"prismatic": "prismatic", "revolute": "pivoting", "continuous": "pivoting", "fixed": "frozen"}


@dataclass(frozen=True)
class FingerChain:
    """One finger of a tool: its links (top first), its drive joint and how that joint moves."""

    name: str                 # its first link below the fork
    links: tuple[str, ...]
    drive: str                # joint name
    motion: str               # prismatic | pivoting | frozen
    joint_types: tuple[str, ...]  # types of the chain's movable joints, top down
    mimics: str | None        # the finger chain whose joint this one's drive follows
    opposes: tuple[str, ...]  # the finger chains it closes against
    moves_with: tuple[str, ...] = ()  # the finger chains whose tips move alongside its own


@dataclass(frozen=True)
class ToolStructure:
    """The structural facts of one candidate tool."""

    fork: str
    mount: str
    fingers: tuple[FingerChain, ...]
    mechanisms: tuple[str, ...]  # first links of movable subtrees that are not fingers

    def grasps(self) -> bool:
        """Some of its fingers close against each other."""
        return any(f.opposes for f in self.fingers)

    def describe(self) -> str:
        """The facts in a short phrase for the model's questions."""
        if not self.fingers:
            return "no moving fingers"
        motions = sorted({f.motion for f in self.fingers})
        words = [f"{len(self.fingers)} moving finger{'s' * (len(self.fingers) > 1)} ({', '.join(motions)})"]
        pairs = sum(len(f.opposes) for f in self.fingers) // 2
        if pairs:
            words.append(f"{pairs} opposing pair{'s' * (pairs > 1)}")
        if any(f.mimics for f in self.fingers):
            words.append("coupled by mimic joints")
        return ", ".join(words)


def nothing_moves(tree: KinematicTree, structure: ToolStructure, mount: str) -> bool:
    """Nothing in the tool moves: no finger or mechanism below its fork, and no movable joint between `mount`
    (where the tool is fixed) and the fork."""
    if structure.fingers or structure.mechanisms:
        return False
    path = tree.chain_to_root(structure.fork)
    between = path[:path.index(mount)] if mount in path else path
    return not any(tree.edge_to(link).movable for link in between)


def fork_of(tree: KinematicTree, leaves: list[str]) -> str:
    """The lowest common ancestor of `leaves` (a lone leaf is its own fork), each link walked once: linear in
    the tree, however many leaves."""
    chain = tree.chain_to_root(leaves[0])
    joins = {link: i for i, link in enumerate(chain)}  # link -> where on `chain` its own chain meets it
    lowest = 0
    for leaf in leaves[1:]:
        walked, link = [], leaf
        while link not in joins:
            walked.append(link)
            link = tree.edge_to(link).parent
        joins.update(dict.fromkeys(walked, joins[link]))
        lowest = max(lowest, joins[link])
    return chain[lowest]


def mount_of(tree: KinematicTree, fork: str) -> str:
    """The link a tool forking at `fork` is bolted to (module docstring); the tree's root carries itself."""
    edge = tree.parent_edge(fork)
    if edge is None:
        return fork
    if tree.is_leaf(fork):
        body = edge.parent
        beside = [link for child in tree.children(body) if child != fork for link in (child, *tree.descendants(child))]
        return body if any(tree.edge_to(link).movable for link in beside) else mount_of(tree, _top_body(tree, body))
    return edge.parent if not edge.movable else fork


def _top_body(tree: KinematicTree, link: str) -> str:
    """The highest of the bodies fixed in series above `link`, each carrying only the next (a suction tool's cup,
    its body): up while the link is fixed to a parent with geometry that carries nothing else."""
    while (edge := tree.parent_edge(link)) is not None and not edge.movable and len(tree.children(edge.parent)) == 1 \
            and not is_frame(tree, edge.parent):
        link = edge.parent
    return link


def tool_structure(tree: KinematicTree, leaves: list[str]) -> ToolStructure:
    """The facts of the tool whose leaves are `leaves`: fork, mount, fingers, mechanisms."""
    fork = fork_of(tree, leaves)
    chains: dict[str, tuple[tuple[str, ...], Edge, str]] = {}
    for child in _moving_children(tree, fork):
        links = (child, *tree.descendants(child))
        tip = max(links, key=lambda link: (len(tree.chain_to_root(link)), _norm(tree.position_in(link, fork))))
        chains[child] = (links, tree.edge_to(child), tip)
    pose = _configuration(tree)
    bodies = {a for a, (links, _, _) in chains.items() if not all(is_frame(tree, link) for link in links)}
    motions = {a: _joint_motions(tree, fork, drive, tip, pose) if a in bodies or not bodies else []
               for a, (_, drive, tip) in chains.items()}  # a chain of bare frames beside bodies closes on nothing
    closing = {a: _closing(motions[a], [m for b in chains if b != a for m in motions[b]]) for a in chains}
    opposes = {a: tuple(b for b in chains if b != a and _opposed(closing[a], closing[b])) for a in chains}
    for a in [a for a in chains if not opposes[a]]:  # a hand written open: its thumb closes on fingers that
        if (thumb := _thumb_closing(a, motions[a], closing)) is not None:  # curl side by side into the palm
            closing[a], closed_on = thumb
            opposes[a] = tuple(dict.fromkeys([*opposes[a], *closed_on]))
            for b in closed_on:
                opposes[b] = tuple(dict.fromkeys([*opposes[b], a]))
    finger_names = [a for a in chains if opposes[a]]
    alongside = {a: tuple(b for b in finger_names if b != a and _alongside(closing[a], closing[b])) for a in finger_names}
    joint_owner = {tree.edge_to(link).joint: a for a in finger_names for link in chains[a][0]}
    fingers = tuple(
        FingerChain(
            name=a,
            links=links,
            drive=drive.joint,
            motion=MOTIONS[drive.joint_type],
            joint_types=tuple(e.joint_type for link in links if (e := tree.edge_to(link)).movable),
            mimics=None if drive.mimic is None or joint_owner.get(drive.mimic) == a else joint_owner.get(drive.mimic),
            opposes=opposes[a],
            moves_with=alongside[a],
        )
        for a in finger_names
        for links, drive, _ in [chains[a]]
    )
    return ToolStructure(fork, mount_of(tree, fork), fingers, tuple(a for a in chains if a not in finger_names))


def _thumb_closing(a: str, own: list[Motion], closing: dict[str, Motion | None]) -> tuple[Motion, tuple[str, ...]] | None:
    """The motion by which chain `a`'s tip closes on two or more chains whose tips move together, and those
    chains: a thumb (the ontology's ThumbChain closes against two or more chains moving together). Fingers
    written open curl into the palm, across the line to the thumb's tip, so they do not oppose it tip to tip
    (_approach); the thumb still closes on each of them (_converging). None where no motion of `a` does."""
    for motion in own:
        closes_on = [b for b, m in closing.items() if b != a and _converging(motion, m)]
        together = tuple(b for b in closes_on if any(_alongside(closing[b], closing[c]) for c in closes_on if c != b))
        if len(together) >= 2:
            return motion, together
    return None


def _converging(a: Motion | None, b: Motion | None) -> bool:
    """Tip `a` closes on tip `b`: their relative motion shortens the gap between them at APPROACH or more of a
    tip's speed, and they do not move alongside each other."""
    if a is None or b is None or _alongside(a, b):
        return False
    (pa, va), (pb, vb) = a, b
    line = _unit(_sub(pb, pa))
    return line is not None and _dot(_sub(va, vb), line) >= APPROACH


def _closing(own: list[Motion], others: list[Motion]) -> Motion | None:
    """A chain's closing motion: of its joints' motions, the one that closes most directly on some
    other chain's tip (an abduction or a turn about the finger's length rarely does), else its drive's."""
    rated = [(max((_approach(m, o) for o in others), default=0.0), -i, m) for i, m in enumerate(own)]
    return max(rated, key=lambda r: r[:2])[2] if rated else None


def _joint_motions(tree: KinematicTree, fork: str, drive: Edge, tip: str, pose: dict[str, float]) -> list[Motion]:
    """The tip's motion under each joint between the drive and the tip that moves on its own (the drive
    first, then every joint following no <mimic>, each with the joints coupled to it), where the tip
    moves at all."""
    path = tree.chain_to_root(tip)
    below = [e for link in reversed(path[:path.index(drive.child)]) if (e := tree.edge_to(link)).independent]
    return [m for e in [drive, *below] if e.joint_type in MOTIONS and (m := _tip_motion(tree, fork, e, tip, pose))]


def _moving_children(tree: KinematicTree, fork: str) -> list[str]:
    """Links hung by a movable joint on the rigid body the fork belongs to below it (its fixed descendants)."""
    found, stack = [], list(reversed(tree.children(fork)))
    while stack:
        link = stack.pop()
        if tree.edge_to(link).movable:
            found.append(link)
        else:
            stack.extend(reversed(tree.children(link)))
    return found


def _tip_motion(tree: KinematicTree, fork: str, drive: Edge, tip: str, pose: dict[str, float]) -> Motion | None:
    """Where the tip is and the direction it moves in as the drive moves positively, with every joint
    of the chain coupled to it by <mimic>, all joints at `pose` (None: it does not move)."""
    point = _in_frame(tree, tip, fork, (0.0, 0.0, 0.0), pose)
    path = tree.chain_to_root(tip)
    velocity = (0.0, 0.0, 0.0)
    for link in path[:path.index(drive.child) + 1]:
        edge = tree.edge_to(link)
        if (rate := _coupling(drive, edge)) and (axis := _unit(_in_frame(tree, link, fork, edge.axis, pose, True))):
            if edge.joint_type == "prismatic":
                part = axis
            else:  # pivoting, or a driven joint written fixed: a rotation about its declared axis
                joint = _in_frame(tree, link, fork, (0.0, 0.0, 0.0), pose)
                part = _cross(axis, (point[0] - joint[0], point[1] - joint[1], point[2] - joint[2]))
            velocity = tuple(v + rate * p for v, p in zip(velocity, part))  # type: ignore[assignment]
    if drive.mimic is not None and drive.mimic_multiplier < 0:  # the drive turns against the joint it follows
        velocity = (-velocity[0], -velocity[1], -velocity[2])
    if _closes_backwards(drive, pose):
        velocity = (-velocity[0], -velocity[1], -velocity[2])
    direction = _unit(velocity) if _dot(velocity, velocity) >= _STILL else None
    return None if direction is None else (point, direction)


def _closes_backwards(drive: Edge, pose: dict[str, float]) -> bool:
    """A joint at zero in the pose whose range reaches further below zero than above it: written open, it closes
    by moving negatively (a finger of range [-1.7, 0], a mirrored thumb of range [-1.0, 0.6])."""
    if drive.limits is None or drive.mimic is not None or pose.get(drive.joint, 0.0) != 0.0:
        return False
    lower, upper = drive.limits
    return -lower > upper


def _configuration(tree: KinematicTree) -> dict[str, float]:
    """Every joint at zero where zero is within every joint's range (fingers as written, open on most
    hands), else every joint halfway through its range (0 without limits); mimic joints following their
    joint."""
    movable = [e for e in tree.edges if e.movable]
    at_zero = all(e.limits is None or e.limits[0] <= 0.0 <= e.limits[1] for e in movable)
    chosen = {e.joint: (0.0 if at_zero or not e.limits else sum(e.limits) / 2) for e in movable}
    return {e.joint: e.mimic_multiplier * chosen.get(e.mimic, 0.0) if e.mimic is not None else chosen[e.joint]
            for e in movable}


def _in_frame(tree: KinematicTree, link: str, ancestor: str, value: Vector, pose: dict[str, float],
              direction: bool = False) -> Vector:
    """A point (or direction) of `link`'s frame in `ancestor`'s frame, with the joints at `pose`."""
    while link != ancestor:
        edge = tree.edge_to(link)
        q = pose.get(edge.joint, 0.0)
        if edge.joint_type in ("revolute", "continuous") and q:
            value = _turn(value, _unit(edge.axis) or (1.0, 0.0, 0.0), q)
        elif edge.joint_type == "prismatic" and q and not direction:
            axis = _unit(edge.axis) or (1.0, 0.0, 0.0)
            value = (value[0] + q * axis[0], value[1] + q * axis[1], value[2] + q * axis[2])
        value = rotate_rpy(edge.origin.rpy, value)
        if not direction:
            value = (value[0] + edge.origin.xyz[0], value[1] + edge.origin.xyz[1], value[2] + edge.origin.xyz[2])
        link = edge.parent
    return value


def _turn(v: Vector, axis: Vector, angle: float) -> Vector:
    """Rodrigues' rotation of v about a unit axis."""
    c, s = math.cos(angle), math.sin(angle)
    k = _cross(axis, v)
    d = _dot(axis, v) * (1 - c)
    return (v[0] * c + k[0] * s + axis[0] * d, v[1] * c + k[1] * s + axis[1] * d, v[2] * c + k[2] * s + axis[2] * d)


def _coupling(drive: Edge, edge: Edge) -> float:
    """How fast `edge` moves when the drive moves at unit rate (0: independent of it)."""
    if edge is drive:
        return 1.0
    if not edge.movable or edge.mimic is None:
        return 0.0
    if edge.mimic == drive.joint:
        return edge.mimic_multiplier
    if edge.mimic == drive.mimic and drive.mimic_multiplier:
        return edge.mimic_multiplier / drive.mimic_multiplier
    return 0.0


def _opposed(a: Motion | None, b: Motion | None) -> bool:
    """Tips that move towards (or away from) each other along the line joining them; tips that
    coincide, in opposite directions."""
    return _approach(a, b) > 0


def _approach(a: Motion | None, b: Motion | None) -> float:
    """How directly two opposed tips close on each other: the smaller share of their motions along the
    line joining them (1 for coinciding tips moving apart), 0 when they do not oppose."""
    if a is None or b is None:
        return 0.0
    (pa, va), (pb, vb) = a, b
    gap = (pb[0] - pa[0], pb[1] - pa[1], pb[2] - pa[2])
    # an offset across both motions brings no tip nearer: the gap in their plane, or along them
    # where they are nearly collinear
    if _norm(across_both := _cross(va, vb)) > _PLANE and (normal := _unit(across_both)):
        across = _dot(gap, normal)
        gap = (gap[0] - across * normal[0], gap[1] - across * normal[1], gap[2] - across * normal[2])
    elif _norm(gap) >= _TOUCHING:
        along = _dot(gap, va)
        gap = (along * va[0], along * va[1], along * va[2])
    line = _unit(gap)
    if line is None or _norm(gap) < _TOUCHING:
        return 1.0 if _dot(va, vb) < OPPOSED else 0.0
    along_a, along_b = _dot(va, line), _dot(vb, line)
    closing = min(abs(along_a), abs(along_b))
    return closing if along_a * along_b < 0 and closing >= APPROACH else 0.0


def _alongside(a: Motion | None, b: Motion | None) -> bool:
    """Tips that move in nearly the same direction (fingers side by side)."""
    return a is not None and b is not None and _dot(a[1], b[1]) > ALONGSIDE


def _dot(a: Vector, b: Vector) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _norm(v: Vector) -> float:
    return math.sqrt(sum(x * x for x in v))


def _unit(v: Vector) -> Vector | None:
    n = _norm(v)
    return None if n == 0 else (v[0] / n, v[1] / n, v[2] / n)


def _cross(a: Vector, b: tuple[float, ...]) -> Vector:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


# --- what the robot's shape says before any question ------------------------------------------------

FRAME_MARK = 0.005  # m: a primitive this small (a 1 mm box, a 0.5 mm sphere) only marks where a frame is
HAND_REACH = 0.3  # m: the farthest a fingertip lies from where its hand's fingers part (a limb reaches further)
MAX_FINGER_JOINTS = 5  # movable joints in one finger, thumb included
TOOL_POINT = 0.03  # m: a tool centre point lies this close to the fingertips' span across the hand, at most
TIP_DEPTH = 0.6  # and at least this share of the way out from where the fingers part to their tips (touch pads on a
# hand's back or sides lie under half of it)
FOOT_BAND = 0.05  # m: feet are the limb tips within this of the robot's lowest point at the zero pose
STANCE = 0.15  # m: how far above its lowest points the root of a robot that stands on them lies, at the least


def hand_leaves(tree: KinematicTree) -> frozenset[str]:
    """The leaves of every hand or gripper the tree's shape shows (hand_mounts)."""
    return frozenset(hand_mounts(hands(tree)))


def hand_mounts(found: list[tuple[ToolStructure, list[str]]]) -> dict[str, str]:
    """Each leaf of the hands `found` (hands) → the hand's mount, read before anything is asked, so that they
    go to the end-effector pass and not to the sensors."""
    return {leaf: structure.mount for structure, leaves in found for leaf in leaves}


def hands(tree: KinematicTree) -> list[tuple[ToolStructure, list[str]]]:
    """Every hand or gripper the tree's shape shows, with its leaves. A hand is a fork (tool_structure) with two
    finger chains or more among its hand-sized moving subtrees (at most MAX_FINGER_JOINTS joints, each with a
    range: a wheel or a caster spins freely; every link within HAND_REACH). Its leaves are those of its
    finger chains, of its other hand-sized moving subtrees (the drive of a hand that opens as a whole), and
    the pure frames fixed to its rigid body that lie out among the fingertips (_among_tips): tool centre points,
    on the hand itself or on the flange it is bolted to.
    A joint that spins (Edge.spins) is a wheel's or a caster's, never a finger's."""
    found = []
    standing = feet(tree)
    for fork in tree.links:
        small = [c for c in _moving_children(tree, fork) if _hand_sized(tree, fork, c)]
        if len(small) < 2:
            continue
        leaves = [link for c in small for link in (c, *tree.descendants(c)) if tree.is_leaf(link)]
        if standing & set(leaves):  # short legs the robot stands on, not fingers
            continue
        structure = tool_structure(tree, leaves)
        fingers = [f for f in structure.fingers if f.name in small]
        if len(fingers) < 2:
            continue
        found.append((structure, list(dict.fromkeys([*leaves, *_tool_points(tree, structure.fork, fingers)]))))
    return found


def beside_hands(tree: KinematicTree, hands_found: list[tuple[ToolStructure, list[str]]]) -> frozenset[str]:
    """Bodies fixed beside one of the hands found (hands) rather than in it: leaves with geometry on the body the
    hand is mounted on, not below where its fingers part (a range sensor or a camera on the wrist a gripper is
    bolted to). A pure frame there may mark the hand's tool point, so frames are not among them."""
    found: set[str] = set()
    for structure, leaves in hands_found:
        mount = set(rigid_body(tree, structure.mount))
        below = {structure.fork, *tree.descendants(structure.fork)}
        found.update(leaf for link in mount for leaf in tree.children(link)
                     if tree.is_leaf(leaf) and leaf not in below and leaf not in leaves and not is_frame(tree, leaf))
    return frozenset(found)


def _tool_points(tree: KinematicTree, fork: str, fingers: list[FingerChain]) -> list[str]:
    body = rigid_body(tree, fork)  # positions in its top link's frame, from the fork
    fork_at = tree.position_in(fork, body[0])

    def at(link: str) -> Vector:
        return _sub(tree.position_in(link, body[0]), fork_at)
    tips = [at(max(f.links, key=lambda link: len(tree.chain_to_root(link)))) for f in fingers]
    centre = (sum(p[0] for p in tips) / len(tips), sum(p[1] for p in tips) / len(tips), sum(p[2] for p in tips) / len(tips))
    span = max(math.dist(p, centre) for p in tips)
    frames = [link for link in body if link != fork and tree.is_leaf(link) and is_frame(tree, link)]
    return [link for link in frames if _among_tips(at(link), centre, span)]


def _among_tips(point: Vector, centre: Vector, span: float) -> bool:
    """A point of the hand's body lies out among its fingertips: at least TIP_DEPTH of the way from the fork to
    their centre, along that line, and within TOOL_POINT of their span across it."""
    reach = _norm(centre)
    if reach == 0:
        return _norm(point) <= span + TOOL_POINT
    along = _dot(point, centre) / reach
    across = math.sqrt(max(_dot(point, point) - along * along, 0.0))
    return along >= TIP_DEPTH * reach and across <= span + TOOL_POINT


def is_frame(tree: KinematicTree, link: str) -> bool:
    """The link is a coordinate frame rather than a body: it has no geometry (a link without evidence counts),
    or only a primitive of at most FRAME_MARK drawn to show where the frame is."""
    facts = tree.evidence.get(link)
    if facts is None or facts.is_pure_frame:
        return True
    extent = facts.extent
    return extent is not None and extent <= FRAME_MARK


def _hand_sized(tree: KinematicTree, fork: str, child: str) -> bool:
    """The moving subtree `child` of `fork` could be a finger: within a hand's size (_within_hand), with no
    joint that spins (a wheel's, a caster's)."""
    links = (child, *tree.descendants(child))
    return _within_hand(tree, fork, links) and not any(tree.edge_to(link).spins for link in links)


def _within_hand(tree: KinematicTree, fork: str, links: tuple[str, ...]) -> bool:
    """At most MAX_FINGER_JOINTS movable joints among `links`, each within HAND_REACH of `fork`."""
    return (sum(tree.edge_to(link).movable for link in links) <= MAX_FINGER_JOINTS
            and all(_norm(tree.position_in(link, fork)) <= HAND_REACH for link in links))


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


def off_limb_ends(tree: KinematicTree, found: list[tuple[ToolStructure, list[str]]]) -> frozenset[str]:
    """Leaves at no limb's end, so never an end effector: where a limb goes on from their body (limb_goes_on),
    or bodies beside one of the hands `found` (beside_hands)."""
    return beside_hands(tree, found) | {leaf for leaf in tree.leaves() if limb_goes_on(tree, leaf)}


def feet(tree: KinematicTree) -> frozenset[str]:
    """The leaves a robot stands on: tips of limbs (two movable joints or more above them) within FOOT_BAND
    of the robot's lowest link origin at the zero pose, on a robot whose root lies STANCE above that point
    and that has two such tips at least. Where a limb ends there is a foot, not a tool."""
    height = {link: tree.position_in(link, tree.root)[2] for link in tree.links}
    lowest = min(height.values())
    if height[tree.root] - lowest < STANCE:
        return frozenset()
    limbs = [leaf for leaf in tree.leaves() if height[leaf] <= lowest + FOOT_BAND
             and sum(tree.edge_to(link).movable for link in tree.chain_to_root(leaf)[:-1]) >= 2]
    return frozenset(limbs) if len(limbs) >= 2 else frozenset()


# --- frames of one body, and where a camera sees from ------------------------------------------------

CAMERA_BODY = 0.1  # m: the frames of one camera lie this close to the body they hang from
VIEWPOINT = 0.005  # m: optical frames closer than this see from one place (one imager)
OPTICAL_AXIS = math.cos(math.radians(15))  # an optical frame's z axis lies along its parent's x axis (REP 103)


def body_of(tree: KinematicTree, a: str, b: str) -> str | None:
    """The link both leaves hang from as parts of one body: by fixed joints through frames (is_frame), within
    CAMERA_BODY of it, each on a branch that leads to one imager alone (None where they do not). A leaf with
    geometry fixed straight to that link, beside an optical frame (REP 103), is the camera body's own housing
    piece (a camera's model frame): it belongs to the body too."""
    body = fork_of(tree, [a, b])
    housings = 0
    for leaf, other in ((a, b), (b, a)):
        path = tree.chain_to_root(leaf)
        branch = path[:path.index(body)]  # leaf ... the body's child
        if not branch or any(tree.edge_to(link).movable for link in branch):
            return None
        if not is_frame(tree, leaf) and len(branch) == 1 and is_optical(tree, other):
            housings += 1
        elif not all(is_frame(tree, link) for link in branch):
            return None
        if any(_imagers_below(tree, link) > 1 for link in branch[1:]):
            return None
        if math.dist(tree.position_in(leaf, body), (0.0, 0.0, 0.0)) > CAMERA_BODY:
            return None
    return body if housings < 2 else None


def _imagers_below(tree: KinematicTree, link: str) -> int:
    """How many imagers a branch link carries: its optical-convention leaves (REP 103), or all its leaves where
    none follows the convention. A link carrying two is a camera of its own (one of a stereo head's pairs)."""
    leaves = [d for d in tree.descendants(link) if tree.is_leaf(d)]
    return sum(is_optical(tree, leaf) for leaf in leaves) or len(leaves)


def frames_of_one_body(tree: KinematicTree, leaves: list[str]) -> list[list[str]]:
    """`leaves` partitioned into the frames of one body (body_of), each set in the order given."""
    return partition(leaves, lambda a, b: body_of(tree, a, b) is not None)


def viewpoints(tree: KinematicTree, leaves: list[str]) -> int:
    """How many places a device's frames see from: their positions at the zero pose, those within VIEWPOINT
    of each other counted once. Where some of the frames follow the optical convention (REP 103: z forward,
    along the x axis of the link they hang from), only those count (a camera's inertial frames see nothing),
    and two of them see from one place when they lie within VIEWPOINT across their line of sight."""
    optical = [leaf for leaf in leaves if is_optical(tree, leaf)]
    places: list[tuple[Vector, Vector | None]] = []  # a point, and the line of sight through it where known
    for leaf in optical or leaves:
        point = tree.position_in(leaf, tree.root)
        sight = _unit(_sub(tree.position_in(leaf, tree.root, (0.0, 0.0, 1.0)), point)) if optical else None
        if all(_apart(point, p, axis) > VIEWPOINT for p, axis in places):
            places.append((point, sight))
    return len(places)


def _apart(a: Vector, b: Vector, sight: Vector | None) -> float:
    """How far apart two frames see from: across `sight`, the line of sight through `b` (a frame further along
    it, as optical frames are often written a centimetre ahead of the lens, sees from the same place)."""
    gap = _sub(a, b)
    if sight is None:
        return _norm(gap)
    along = _dot(gap, sight)
    return math.sqrt(max(_dot(gap, gap) - along * along, 0.0))


def _sub(a: Vector, b: Vector) -> Vector:
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def is_optical(tree: KinematicTree, leaf: str) -> bool:
    """The leaf follows the optical convention (REP 103): its z axis, the line of sight, along its parent's x axis."""
    parent = tree.parent(leaf)
    if parent is None:
        return False
    origin = tree.position_in(leaf, parent)
    z = tuple(p - o for p, o in zip(tree.position_in(leaf, parent, (0.0, 0.0, 1.0)), origin))
    return z[0] >= OPTICAL_AXIS


ALIKE_TOLERANCE = 1e-3  # m: joint offsets of alike chains agree to a millimetre (mirror images, copies)


def alike_leaves(tree: KinematicTree, leaves: list[str]) -> list[list[str]]:
    """`leaves` partitioned into sets of alike ones (in the order given): two leaves are alike when the chains
    from their lowest common ancestor down to each have the same shape (joint types, offset lengths, the
    leaves' own geometry and mass) and move, at least one joint of each being movable: the fingers of a
    hand, mirrored limbs, a quadruped's legs. Fixed frames side by side on one body are never alike here:
    a camera and an IMU bolted at equal distances are not the same thing."""
    paths = {leaf: tree.chain_to_root(leaf)[::-1] for leaf in leaves}
    return partition(leaves, lambda a, b: _alike(tree, paths[a], paths[b]))


def alike_sets(tree: KinematicTree, leaves: list[str], same: Callable[[str, str], bool]) -> list[list[str]]:
    """alike_leaves, each set split further where `same` (asked of two alike leaves) says their questions differ:
    the sets a stage asks one question for, the first leaf standing for all."""
    return [part for alike in alike_leaves(tree, leaves) for part in partition(alike, same)]


T = TypeVar("T")


def partition(items: Sequence[T], joined: Callable[[T, T], bool]) -> list[list[T]]:
    """`items` in the classes of the transitive closure of `joined` (asked once for each pair of items not
    already in one class), each class in the items' order, the classes in the order of their first items."""
    parent = list(range(len(items)))

    def find(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for i, a in enumerate(items):
        for j, b in enumerate(items[:i]):
            if find(i) != find(j) and joined(a, b):
                parent[find(i)] = find(j)
    classes: dict[int, list[T]] = {}
    for i, item in enumerate(items):
        classes.setdefault(find(i), []).append(item)
    return list(classes.values())


def _alike(tree: KinematicTree, a: tuple[str, ...], b: tuple[str, ...]) -> bool:
    common = 0
    while common < min(len(a), len(b)) and a[common] == b[common]:
        common += 1
    below_a, below_b = a[common:], b[common:]
    if not below_a or len(below_a) != len(below_b):
        return False
    edges = [(tree.edge_to(x), tree.edge_to(y)) for x, y in zip(below_a, below_b)]
    if not any(e.movable for e, _ in edges):
        return False
    for e, f in edges:
        if e.joint_type != f.joint_type or abs(_norm(e.origin.xyz) - _norm(f.origin.xyz)) > ALIKE_TOLERANCE:
            return False
    facts_a, facts_b = tree.evidence.get(a[-1]), tree.evidence.get(b[-1])
    if facts_a is None or facts_b is None:
        return facts_a is facts_b
    return (facts_a.shape, round(facts_a.mass or 0.0, 3), facts_a.is_pure_frame) == \
        (facts_b.shape, round(facts_b.mass or 0.0, 3), facts_b.is_pure_frame)


LOOP_GAP = 0.001  # m: the two frames a closed kinematic loop is cut at coincide within this at the zero pose


def loop_closures(tree: KinematicTree) -> frozenset[str]:
    """Leaf frames where a closed kinematic loop is cut to make a tree (a Stewart platform's rods, a linkage's
    bars): bare frames fixed to their links that coincide with another such frame at the zero pose, across a
    joint that moves (the path between them passes through one). They mark a constraint for a solver, not a
    device; a camera's frame and its optical twin on one link coincide with nothing between them."""
    frames = [leaf for leaf in tree.leaves() if tree.parent(leaf) is not None
              and not tree.edge_to(leaf).movable and is_frame(tree, leaf)]
    cells: dict[tuple[int, int, int], list[tuple[str, Vector]]] = {}
    for leaf in frames:
        point = tree.position_in(leaf, tree.root)
        cells.setdefault(tuple(round(x / LOOP_GAP) for x in point), []).append((leaf, point))  # type: ignore[arg-type]
    found: set[str] = set()
    for (i, j, k), members in cells.items():
        near = [m for di in (-1, 0, 1) for dj in (-1, 0, 1) for dk in (-1, 0, 1)
                for m in cells.get((i + di, j + dj, k + dk), ())]
        for a, pa in members:
            for b, pb in near:
                if a != b and math.dist(pa, pb) <= LOOP_GAP and _moves_between(tree, a, b):
                    found.update((a, b))
    return frozenset(found)


def _moves_between(tree: KinematicTree, a: str, b: str) -> bool:
    """A joint that moves lies on the tree's path between links `a` and `b`."""
    meet = fork_of(tree, [a, b])
    return any(tree.edge_to(link).movable for leaf in (a, b)
               for path in [tree.chain_to_root(leaf)] for link in path[:path.index(meet)])
