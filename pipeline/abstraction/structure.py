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
  <mimic>, directly or through other joints that follow it (an underactuated hand's finger joints following
  its synergy joint, each finger's second half following its first), the one whose motion closes most
  directly on another chain's tip; a joint that only
  spreads a finger sideways or turns a thumb about its own length does not (a drive that itself
  follows another joint moves as that joint closes: a jaw mimicking the other with multiplier -1 and
  the same axis turns the other way; fingers following a thumb whose range reaches below zero close as
  it turns negatively). Motions are taken with every joint at zero,
  as written (open, on most hands), or, where zero lies outside some joint's range, every joint
  halfway through its range; where, of two chains with bodies or more, one then closes on none, once more
  half closed (_half_closed), a finger's spread joints (square to the parallel joints that curl it) left where
  they were and not its closing joint. A chain pivoting about the same axis as another chain's drive and reaching
  less far (_linkages: a four-bar's crank beside the finger it moves) is that finger's linkage. A driven
  subtree that opposes no other, whose tip sits on its drive's axis, that hangs on a planar or
  floating joint, or whose links are all bare frames beside chains with bodies (a virtual joint the
  fingers mimic, such as a finger-distance joint), is a *mechanism* (a motor, a lead screw), not a finger; so is a
  subtree whose drive spins (turns without bound, Edge.spins) where the other chains grasp without it (a servo's horn
  beside the fingers it drives through a linkage): a finger closes over a bounded arc. A tip
  whose frame lies on its drive's axis is read where its mass is (a one-link finger hung on its hinge: a rotor's
  mass lies on its axis too), unless it turns with a finger jointed beyond its drive (a four-bar's bar); where
  nothing closes so, jaws written as one link each are looked at again where their mass is.
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
definitions do that, applied by a reasoner (pipeline.knowledge.reasoning).
"""
from __future__ import annotations

import math
from collections.abc import Set as AbstractSet
from dataclasses import dataclass, replace

from urdfkb.pipeline.abstraction.frames import is_frame
from urdfkb.pipeline.reading.tree import Edge, KinematicTree, Vector, fork_of, rotate_rpy
from urdfkb.pipeline.abstraction.vectors import cross, dot, norm, off_axis, sub, turn, unit

OPPOSED = -0.5   # coinciding tips: cosine of their directions of motion below which they oppose
ALONGSIDE = 0.5  # cosine of two tips' directions of motion above which they move together
APPROACH = 0.4   # separate tips: share of each tip's motion along the line joining them, with opposite signs
_PLANE = 0.5     # sine of the angle between two tips' motions above which they span a plane
_TOUCHING = 1e-4  # metres: tips closer than this coincide (two jaws on one slide)
_STILL = 1e-9    # squared speed below which a tip does not move (it lies on its drive's axis)
_SQUARE = 0.2    # |cosine| below which two joint axes are square to each other (within about 12 degrees)
_PARALLEL = 0.95  # |cosine| above which two joint axes are parallel (within about 18 degrees)
_FULL_TURN = 2 * math.pi - 0.01  # rad: a range this wide turns all the way round (+-3.14, as files write a free pin)
_LINKAGE = 0.7    # a chain pivoting on another's axis and reaching less than this share as far is its linkage
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
    linkages: tuple[str, ...] = ()  # those of them that are fingers' linkages (_linkages)

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
    """The facts of the tool whose leaves are `leaves`: fork, mount, fingers, mechanisms (_fingers_of); a chain
    whose drive spins is a mechanism where the other chains grasp without it."""
    fork = fork_of(tree, leaves)
    chains: dict[str, tuple[tuple[str, ...], Edge, str]] = {}
    bars: dict[str, AbstractSet[str]] = {}
    for child in moving_children(tree, fork):
        links = (child, *tree.descendants(child))
        bars[child] = own_bars = linkage_bars(tree, links)
        tip = max((link for link in links if link not in own_bars),  # the finger's own links, its bars aside
                  key=lambda link: (len(tree.chain_to_root(link)), norm(tree.position_in(link, fork))))
        chains[child] = (links, tree.edge_to(child), tip)
    spinning = [a for a, (_, drive, _) in chains.items() if drive.spins]
    if spinning and len(chains) - len(spinning) >= 2:
        rest = _fingers_of(tree, fork, {a: c for a, c in chains.items() if a not in spinning}, bars)
        if rest.grasps():
            return replace(rest, mechanisms=tuple(a for a in chains if a not in {f.name for f in rest.fingers}))
    return _fingers_of(tree, fork, chains, bars)


def _fingers_of(tree: KinematicTree, fork: str, chains: dict[str, tuple[tuple[str, ...], Edge, str]],
                bars_of: dict[str, AbstractSet[str]]) -> ToolStructure:
    """The tool's facts from its chains. Fingers' linkages (_linkages) close on nothing, and with the bars inside
    fingers (linkage_bars, in `bars_of` by chain) neither end a finger nor decide the pose; where, of two chains with
    bodies or more, one closes on none at the written pose, the fingers are looked at again half closed
    (_half_closed), and that look is kept where more chains close on others (fingers written flat, curling the same
    way at first)."""
    bars = {bar for a in chains for bar in bars_of[a]}
    bodies = {a for a, (links, _, _) in chains.items() if not all(is_frame(tree, link) for link in links)}
    pivots = _pivots(tree, fork, chains)
    linkages = _linkages(pivots)
    held = {tree.edge_to(link).joint for link in [*bars, *(link for a in linkages for link in chains[a][0])]}
    pose = _configuration(tree, held)
    bars_beside = _four_bar_bars(pivots)
    structure = _structure_at(tree, fork, chains, bodies, linkages, bars_beside, pose)
    if len(fingered := bodies - linkages) >= 2 and _closing_on_others(structure) < len(fingered):
        spreads = {joint for a in fingered for joint in _spreads(tree, chains[a][0])}
        half_closed = _half_closed(tree, chains, fingered, pose, spreads)
        again = _structure_at(tree, fork, chains, bodies, linkages, bars_beside, half_closed, spreads, closing_sense=True)
        if _closing_on_others(again) > _closing_on_others(structure):
            return again
    jaws = {a for a in bodies - linkages if chains[a][0] == (a,) and (f := tree.evidence.get(a)) and f.centre}
    if not structure.fingers and jaws and len(bodies - linkages) >= 2:  # a jaw or thumb written as one link, its
        # frame on its hinge, closing on another jaw or on fingers
        again = _structure_at(tree, fork, chains, bodies, linkages, bars_beside, pose, at_mass=frozenset(jaws))
        if again.fingers:
            return again
    return structure


def _closing_on_others(structure: ToolStructure) -> int:
    """How many of the tool's fingers close on another (a finger curling beside one does not)."""
    return sum(1 for finger in structure.fingers if finger.opposes)


def _structure_at(tree: KinematicTree, fork: str, chains: dict[str, tuple[tuple[str, ...], Edge, str]],
                  bodies: set[str], linkages: AbstractSet[str], bars_beside: AbstractSet[str], pose: dict[str, float],
                  spreads: AbstractSet[str] = frozenset(), closing_sense: bool = False,
                  at_mass: AbstractSet[str] = frozenset()) -> ToolStructure:
    """The tool's fingers and mechanisms as its chains move from `pose` (a finger opposes another, or curls beside
    one that does: _alongside), none closing by a joint of `spreads`
    where it moves by another, and none of `linkages` (other chains' linkages) closing at all; `closing_sense`:
    each joint moving the way its range reaches further wherever it stands (_closes_backwards), so fingers
    written with mirrored signs close alike away from zero too; `at_mass`: chains whose tip is taken at its centre
    of mass (a jaw written as one link has its frame on its hinge, where it does not move); a tip that does not move
    at its frame is taken there too (a finger of one link following another's joint, its frame on its own hinge),
    unless its chain is in `bars_beside` (it turns with a finger jointed beyond its drive: a four-bar's bar)."""
    def moving(a: str, drive: Edge, tip: str) -> list[Motion]:
        found = _joint_motions(tree, fork, drive, tip, pose, spreads, closing_sense, a in at_mass)
        if found or a in at_mass or a in bars_beside:
            return found
        return _joint_motions(tree, fork, drive, tip, pose, spreads, closing_sense, True)

    motions = {a: moving(a, drive, tip) if (a in bodies or not bodies) and a not in linkages else []
               for a, (_, drive, tip) in chains.items()}  # a chain of bare frames beside bodies closes on nothing
    closing = {a: _closing(motions[a], [m for b in chains if b != a for m in motions[b]]) for a in chains}
    opposes = {a: tuple(b for b in chains if b != a and _opposed(closing[a], closing[b])) for a in chains}
    for a in [a for a in chains if not opposes[a]]:  # a hand written open: its thumb closes on fingers that
        if (thumb := _thumb_closing(a, motions[a], closing)) is not None:  # curl side by side into the palm
            closing[a], closed_on = thumb
            opposes[a] = tuple(dict.fromkeys([*opposes[a], *closed_on]))
            for b in closed_on:
                opposes[b] = tuple(dict.fromkeys([*opposes[b], a]))
    opposing = [a for a in chains if opposes[a]]
    finger_names = [a for a in chains if opposes[a] or (a in bodies and a not in linkages and any(
        _alongside(closing[a], closing[b]) for b in opposing if b != a))]  # a ring finger curling beside the index
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
    return ToolStructure(fork, mount_of(tree, fork), fingers, tuple(a for a in chains if a not in finger_names),
                         tuple(a for a in chains if a in linkages))


@dataclass(frozen=True)
class _Pivot:
    """A chain turning about its drive (revolute or continuous), in the fork's frame: where and about which axis it
    pivots, how far its links reach from there, whether it is jointed beyond its drive, and the axis it turns
    about as its source joint moves positively (a <mimic> with a negative multiplier turns it backwards)."""
    at: Vector
    axis: Vector
    reach: float
    jointed: bool
    drive: Edge
    turning: Vector


def _pivots(tree: KinematicTree, fork: str, chains: dict[str, tuple[tuple[str, ...], Edge, str]]) -> dict[str, _Pivot]:
    """The chains of `chains` that pivot, by name."""
    pivots = {}
    for a, (links, drive, _) in chains.items():
        if drive.joint_type in ("revolute", "continuous") and (axis := unit(_in_frame(tree, a, fork, drive.axis, {}, True))):
            at = tree.position_in(a, fork)
            pivots[a] = _Pivot(
                at=at,
                axis=axis,
                reach=max(norm(sub(tree.position_in(link, fork), at)) for link in links),
                jointed=any(tree.edge_to(link).movable for link in links[1:]),
                drive=drive,
                turning=axis if drive.mimic is None or drive.mimic_multiplier >= 0 else (-axis[0], -axis[1], -axis[2]),
            )
    return pivots


def _beside_jointed(pivots: dict[str, _Pivot], a: str) -> list[_Pivot]:
    """The other pivoting chains jointed beyond their drive (fingers a linkage may curl) whose axis is parallel to
    chain `a`'s."""
    return [other for b, other in pivots.items()
            if b != a and other.jointed and abs(dot(pivots[a].axis, other.axis)) > _PARALLEL]


def _one_source(drive: Edge, other: Edge) -> bool:
    """Both drives turn by one joint: one follows the other by <mimic>, or both follow a third."""
    return (drive.mimic or drive.joint) == (other.mimic or other.joint)


def _four_bar_bars(pivots: dict[str, _Pivot]) -> set[str]:
    """Chains whose drive turns by the same joint as a parallel chain jointed beyond its drive: each may be the bar
    of a four-bar beside the finger it curls (a Robotiq 2F's inner knuckle), which a URDF writes as a chain of its
    own."""
    return {a for a, pivot in pivots.items() if any(_one_source(pivot.drive, other.drive)
                                                    for other in _beside_jointed(pivots, a))}


def _linkages(pivots: dict[str, _Pivot]) -> set[str]:
    """Chains that are another chain's linkage: a chain whose drive pivots about an axis parallel to another chain's
    drive, that other chain jointed beyond its drive (a finger that the linkage curls), and whose link origins lie
    less than _LINKAGE as far from its pivot at the written pose, where the two pivots lie on one pin (_on_pin: a
    four-bar's crank beside the finger it moves, at its hinge or, turning freely, beside it on the same pin) or
    apart in the plane the two turn in (their offset square to the axes, and shorter than the linkage reaches) with
    one joint turning both the same way (<mimic>: a parallel four-bar's two bars on the tool's body, the finger hung
    from one of them). A URDF tree cannot close a loop, so such a linkage is written as a chain of its own. Which way
    a crank turns is arbitrary where it follows no <mimic>, so whether it closes on its finger says nothing; two jaws
    sharing one pin, each one rigid link, stay fingers."""
    found = set()
    for a, pivot in pivots.items():
        for other in _beside_jointed(pivots, a):
            if pivot.reach >= _LINKAGE * other.reach:
                continue
            offset = sub(pivot.at, other.at)
            if _on_pin(offset, pivot.axis, pivot.drive) or (
                    _one_source(pivot.drive, other.drive) and dot(pivot.turning, other.turning) > _PARALLEL
                    and norm(offset) < pivot.reach and abs(dot(offset, pivot.axis)) < _SQUARE * norm(offset)):
                found.add(a)
    return found


def _on_pin(offset: Vector, axis: Vector, edge: Edge) -> bool:
    """A pivot `offset` from another, about a parallel `axis`, on that other's pin: at the same point (within
    _TOUCHING), or apart along the pin where `edge` turns freely (through a full turn, as files write it, or
    continuous with no limits: a joint the loop it closes holds, not a finger's hinge beside another's)."""
    if off_axis(offset, axis) >= _TOUCHING:
        return False
    if norm(offset) < _TOUCHING:
        return True
    if edge.limits is None:  # a revolute joint with no range given is read so too (a <limit> wanting a bound)
        return edge.joint_type == "continuous"
    return edge.limits[1] - edge.limits[0] >= _FULL_TURN


def linkage_bars(tree: KinematicTree, links: tuple[str, ...]) -> frozenset[str]:
    """The links of `links` (a moving subtree, top first) that are bars of a linkage inside it rather than a
    finger's own segments: each subtree hung by a pivot on a link of it on a pin of that link's own (_on_pin: the
    pin it turns on, or the one another child of it pivots on; beside that pivot along the pin where it turns
    freely), whose link origins lie less than _LINKAGE as far out from that pin as those of the link's other
    children (those on that pin, in the second case). A four-bar's bars are so written as branches, since a URDF tree cannot close a loop; a joint
    written twice in series (a spring beside a drive: no other child beside it) carries the rest of the finger
    and is no bar."""
    found = set[str]()

    def pivot(link: str) -> tuple[Vector, Vector] | None:  # where the link's joint lies and its axis, in the parent's frame
        e = tree.edge_to(link)
        axis = unit(rotate_rpy(e.origin.rpy, e.axis)) if e.joint_type in ("revolute", "continuous") else None
        return None if axis is None else (e.origin.xyz, axis)

    def reach(link: str, at: Vector, axis: Vector) -> float:  # how far out from the pin its link origins lie
        parent = tree.edge_to(link).parent
        return max(off_axis(sub(tree.position_in(x, parent), at), axis) for x in (link, *tree.descendants(link)))

    for link in links[1:]:
        if link in found or (own := pivot(link)) is None:
            continue
        at, parent = own[0], tree.edge_to(link).parent
        above = tree.edge_to(parent) if parent != tree.root else None
        on_own_pin = above is not None and above.joint_type in ("revolute", "continuous") \
            and (axis := unit(above.axis)) is not None and abs(dot(own[1], axis)) > _PARALLEL \
            and _on_pin(at, axis, tree.edge_to(link))
        others = [other for other in tree.children(parent) if other != link]
        sharing = [other for other in others if (theirs := pivot(other)) is not None
                   and abs(dot(own[1], theirs[1])) > _PARALLEL and _on_pin(sub(at, theirs[0]), own[1], tree.edge_to(link))]
        if not (on_own_pin or sharing):
            continue
        rivals = others if on_own_pin else sharing  # the rest of the finger, which a bar reaches less far than
        if rivals and reach(link, at, own[1]) < _LINKAGE * max(reach(other, at, own[1]) for other in rivals):
            found.update((link, *tree.descendants(link)))
    return frozenset(found)


def _half_closed(tree: KinematicTree, chains: dict[str, tuple[tuple[str, ...], Edge, str]], bodies: set[str],
                 pose: dict[str, float], spreads: AbstractSet[str]) -> dict[str, float]:
    """`pose` with the joint at the root of the <mimic> chain of every joint of the chains with bodies that does not
    spread its finger (`spreads`) (the joint itself where it follows none; an underactuated hand's synergy joint;
    another finger's joint, even one that spreads its own finger, as the Schunk SVH's ring and little fingers follow
    its thumb's opposition) halfway through its range where it is revolute or prismatic and has one, and every joint
    following those, directly or through others, with them: a hand written flat, its fingers curling the same way
    at first, seen as it grasps. Spread joints no other follows, and joints without a range (continuous), stay where
    `pose` has them."""
    moved = dict(pose)
    changed = set()
    for a in bodies:
        for link in chains[a][0]:
            e = tree.edge_to(link)
            if e.joint in spreads or not e.movable:
                continue
            source = source_joint(tree, e)  # the joint it follows, or itself: a synergy joint outside the fingers too
            if source.limits is not None and source.joint_type in ("revolute", "prismatic"):
                lower, upper = source.limits
                moved[source.joint] = (lower + upper) / 2
                changed.add(source.joint)
    while following := [e for e in tree.edges if e.movable and e.mimic in changed and e.joint not in changed]:
        for e in following:  # the joints following them, directly or through others
            moved[e.joint] = e.mimic_multiplier * moved[e.mimic]  # type: ignore[index]
            changed.add(e.joint)
    return moved


def _spreads(tree: KinematicTree, links: tuple[str, ...]) -> set[str]:
    """Joints that spread a finger sideways: a pivot of a chain of three pivots or more whose axis is square to
    the axis of every other pivot of the chain, those all parallel to one another (the joints that curl it)."""
    pivots = [(e.joint, axis) for link in links if (e := tree.edge_to(link)).joint_type in ("revolute", "continuous")
              and (axis := unit(_in_frame(tree, link, links[0], e.axis, {}, True)))]
    found = set()
    for joint, axis in pivots:
        others = [other for name, other in pivots if name != joint]
        if len(others) >= 2 and all(abs(dot(axis, o)) < _SQUARE for o in others) \
                and all(abs(dot(others[0], o)) > _PARALLEL for o in others[1:]):
            found.add(joint)
    return found


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
    line = unit(sub(pb, pa))
    return line is not None and dot(sub(va, vb), line) >= APPROACH


def _closing(own: list[Motion], others: list[Motion]) -> Motion | None:
    """A chain's closing motion: of its joints' motions, the one that closes most directly on some
    other chain's tip (an abduction or a turn about the finger's length rarely does), else its drive's."""
    rated = [(max((_approach(m, o) for o in others), default=0.0), -i, m) for i, m in enumerate(own)]
    return max(rated, key=lambda r: r[:2])[2] if rated else None


def _joint_motions(tree: KinematicTree, fork: str, drive: Edge, tip: str, pose: dict[str, float],
                   spreads: AbstractSet[str] = frozenset(), closing_sense: bool = False,
                   at_mass: bool = False) -> list[Motion]:
    """The tip's motion under each joint between the drive and the tip that moves on its own (the drive
    first, then every joint following no <mimic>, each with the joints coupled to it), where the tip
    moves at all; a joint of `spreads` only where no other moves it."""
    path = tree.chain_to_root(tip)
    below = [e for link in reversed(path[:path.index(drive.child)]) if (e := tree.edge_to(link)).independent]
    found = [(e.joint, m) for e in [drive, *below]
             if e.joint_type in MOTIONS and (m := _tip_motion(tree, fork, e, tip, pose, closing_sense, at_mass))]
    return [m for joint, m in found if joint not in spreads] or [m for _, m in found]


def moving_children(tree: KinematicTree, fork: str) -> list[str]:
    """Links hung by a movable joint on the rigid body the fork belongs to below it (its fixed descendants)."""
    found, stack = [], list(reversed(tree.children(fork)))
    while stack:
        link = stack.pop()
        if tree.edge_to(link).movable:
            found.append(link)
        else:
            stack.extend(reversed(tree.children(link)))
    return found


def _tip_motion(tree: KinematicTree, fork: str, drive: Edge, tip: str, pose: dict[str, float],
                closing_sense: bool = False, at_mass: bool = False) -> Motion | None:
    """Where the tip is and the direction it moves in as the drive moves positively (as it closes, by
    _closes_backwards; a drive that follows another joint by <mimic>, as that joint closes: a hand's fingers
    following its thumb, which closes negatively), with every joint of the chain coupled to it by <mimic>, all
    joints at `pose` (None: it does not move); `at_mass`: the tip's centre of mass, not its frame's origin."""
    facts = tree.evidence.get(tip)
    centre = facts.centre if at_mass and facts is not None and facts.centre is not None else (0.0, 0.0, 0.0)
    point = _in_frame(tree, tip, fork, centre, pose)
    path = tree.chain_to_root(tip)
    velocity = (0.0, 0.0, 0.0)
    source = source_joint(tree, drive)
    for link in path[:path.index(drive.child) + 1]:
        edge = tree.edge_to(link)
        if (rate := _rate(tree, source, edge)) and (axis := unit(_in_frame(tree, link, fork, edge.axis, pose, True))):
            if edge.joint_type == "prismatic":
                part = axis
            else:  # pivoting, or a driven joint written fixed: a rotation about its declared axis
                joint = _in_frame(tree, link, fork, (0.0, 0.0, 0.0), pose)
                part = cross(axis, (point[0] - joint[0], point[1] - joint[1], point[2] - joint[2]))
            velocity = tuple(v + rate * p for v, p in zip(velocity, part))  # type: ignore[assignment]
    if _closes_backwards(source, pose, closing_sense):  # as the joint that drives it closes
        velocity = (-velocity[0], -velocity[1], -velocity[2])
    direction = unit(velocity) if dot(velocity, velocity) >= _STILL else None
    return None if direction is None else (point, direction)


def _closes_backwards(drive: Edge, pose: dict[str, float], anywhere: bool = False) -> bool:
    """A joint at zero in the pose (`anywhere`: wherever it stands) whose range reaches further below zero than
    above it: written open, it closes by moving negatively (a finger of range [-1.7, 0], a mirrored thumb of range
    [-1.0, 0.6])."""
    if drive.limits is None or drive.mimic is not None or (not anywhere and pose.get(drive.joint, 0.0) != 0.0):
        return False
    lower, upper = drive.limits
    return -lower > upper


def _configuration(tree: KinematicTree, held: AbstractSet[str] = frozenset()) -> dict[str, float]:
    """Every joint at zero where zero is within the range of every joint but those `held` (fingers as
    written, open on most hands; a linkage's joints, held by the loop they close, say nothing of where the
    fingers stand), else every joint halfway through its range (0 without limits); mimic joints following
    their joint."""
    movable = [e for e in tree.edges if e.movable]
    at_zero = all(e.limits is None or e.limits[0] <= 0.0 <= e.limits[1] for e in movable if e.joint not in held)
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
            value = turn(value, unit(edge.axis) or (1.0, 0.0, 0.0), q)
        elif edge.joint_type == "prismatic" and q and not direction:
            axis = unit(edge.axis) or (1.0, 0.0, 0.0)
            value = (value[0] + q * axis[0], value[1] + q * axis[1], value[2] + q * axis[2])
        value = rotate_rpy(edge.origin.rpy, value)
        if not direction:
            value = (value[0] + edge.origin.xyz[0], value[1] + edge.origin.xyz[1], value[2] + edge.origin.xyz[2])
        link = edge.parent
    return value


def followed(tree: KinematicTree, edge: Edge) -> list[tuple[Edge, float]]:
    """The joints `edge` follows by <mimic>, itself first, each with how fast `edge` moves when that joint moves at
    unit rate (the product of the multipliers up to it); the walk ends at a joint following none, at a missing one
    or where the chain turns back on itself."""
    by_joint = {e.joint: e for e in tree.edges}
    chain, rate, seen = [(edge, 1.0)], 1.0, {edge.joint}
    current = edge
    while current.mimic is not None and current.mimic in by_joint and current.mimic not in seen:
        rate *= current.mimic_multiplier
        current = by_joint[current.mimic]
        chain.append((current, rate))
        seen.add(current.joint)
    return chain


def source_joint(tree: KinematicTree, drive: Edge) -> Edge:
    """The joint that moves on its own at the root of the drive's <mimic> chain (the drive itself where it follows
    none): an underactuated hand's synergy joint that every finger joint follows, directly or through another."""
    return followed(tree, drive)[-1][0]


def _rate(tree: KinematicTree, source: Edge, edge: Edge) -> float:
    """How fast `edge` moves when `source` moves at unit rate (0: it does not follow `source`)."""
    if not edge.movable:
        return 0.0
    return next((rate for joint, rate in followed(tree, edge) if joint.joint == source.joint), 0.0)


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
    if norm(across_both := cross(va, vb)) > _PLANE and (normal := unit(across_both)):
        across = dot(gap, normal)
        gap = (gap[0] - across * normal[0], gap[1] - across * normal[1], gap[2] - across * normal[2])
    elif norm(gap) >= _TOUCHING:
        along = dot(gap, va)
        gap = (along * va[0], along * va[1], along * va[2])
    line = unit(gap)
    if line is None or norm(gap) < _TOUCHING:
        return 1.0 if dot(va, vb) < OPPOSED else 0.0
    along_a, along_b = dot(va, line), dot(vb, line)
    closing = min(abs(along_a), abs(along_b))
    return closing if along_a * along_b < 0 and closing >= APPROACH else 0.0


def _alongside(a: Motion | None, b: Motion | None) -> bool:
    """Tips that move in nearly the same direction (fingers side by side)."""
    return a is not None and b is not None and dot(a[1], b[1]) > ALONGSIDE
