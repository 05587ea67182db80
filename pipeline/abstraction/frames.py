"""Frames rather than bodies: the leaves that only mark a frame, the frames of one body, where a camera sees
from, the frames where a closed kinematic loop is cut, the leaves that only add to a body's collision shape, and
the bodies that are thin rods.
"""
from __future__ import annotations

import math
from collections.abc import Iterable

from urdfkb.pipeline.abstraction.alike import partition
from urdfkb.pipeline.reading.tree import KinematicTree, Vector, fork_of
from urdfkb.pipeline.abstraction.vectors import dot, norm, sub, unit

FRAME_MARK = 0.005  # m: a primitive this small (a 1 mm box, a 0.5 mm sphere) only marks where a frame is
PLACEHOLDER = 0.02  # m: a virtual joint's dummy link drawn this small (a 1 cm box) stands for no part of the robot
CAMERA_BODY = 0.1  # m: the frames of one camera lie this close to the body they hang from
SQUARE = 0.1  # |cosine| under which two unit axes are square to each other
VIEWPOINT = 0.005  # m: optical frames closer than this see from one place (one imager)
BUILT_IN = 0.02  # m: a camera's built-in sensors' frames lie this close to its imager's (the L515's IMU 14 mm away;
# the eyes of a stereo pair hang 5 to 12 cm apart)
MIRROR_EPS = 0.02  # m: two parts (limbs, their attachment points, a pair's eyes) this near each other's mirror
# image across a plane of the root pair across it
OPTICAL_AXIS = math.cos(math.radians(15))  # an optical frame's z axis lies along its parent's x axis (REP 103)
LINE_OF_SIGHT = math.cos(math.radians(11))  # the imagers of one camera look the same way, within this: halfway
# between the most one camera's imagers part (a Femto Bolt's depth imager, 8 degrees from its colour imager) and the
# least two cameras on one face do (a legged robot's face cameras, 14 to 60 degrees apart)
SAME_PLACE = 1e-6  # m: a fixed joint shorter than this leaves its child at its parent's origin
MARK_PLACE = 0.001  # m: a bare frame this near a drawn piece on the same link marks that piece
ROD_LENGTH = 4.0  # a rod is at least this many times as long as it is thick (poles, standoffs, antennas: 5 to 17)
ROD_THICKNESS = 0.02  # m: and at most this thick (they are 8 to 12 mm; a stereo camera drawn as a cylinder, 3 cm)


def is_frame(tree: KinematicTree, link: str) -> bool:
    """The link is a coordinate frame rather than a body: it has no geometry (a link without evidence counts),
    or only a primitive of at most FRAME_MARK drawn to show where the frame is."""
    facts = tree.evidence.get(link)
    if facts is None or facts.is_pure_frame:
        return True
    extent = facts.extent
    return extent is not None and extent <= FRAME_MARK


def placing_joints(tree: KinematicTree) -> frozenset[str]:
    """The joints that place the whole robot rather than move a part of it: the run of movable joints hanging from
    frames alone from the root (or placeholders), above a first body, where that run holds a floating or
    planar joint or two prismatic joints on axes square to each other (a planar base's virtual x, y and yaw joints,
    written to move it without its wheels). A rail under an arm, a pan and tilt or an arm's first joint on a bare
    root frame is no such run."""
    run = [e for e in tree.edges if e.movable and all(placeholder(tree, link) for link in tree.chain_to_root(e.parent))
           and not all(is_frame(tree, link) for link in (e.child, *tree.descendants(e.child)))]
    sliding = [d for e in run if e.joint_type == "prismatic"
               and (d := unit(tree.direction_in(e.child, tree.root, e.axis))) is not None]
    square = any(abs(dot(a, b)) < SQUARE for i, a in enumerate(sliding) for b in sliding[:i])
    placing = square or any(e.joint_type in ("floating", "planar") for e in run)
    return frozenset(e.joint for e in run) if placing else frozenset()


def placeholder(tree: KinematicTree, link: str) -> bool:
    """A frame (is_frame), or a link drawn as a primitive of at most PLACEHOLDER alone: what a virtual joint's dummy
    link is given so that a simulator keeps it (a 1 cm box), no part of the robot."""
    facts = tree.evidence.get(link)
    return is_frame(tree, link) or (facts is not None and not facts.meshes and facts.extent is not None
                                    and facts.extent <= PLACEHOLDER)


def body_of(tree: KinematicTree, a: str, b: str) -> str | None:
    """The link both leaves hang from as parts of one body: by fixed joints through frames (is_frame), within
    CAMERA_BODY of it or within VIEWPOINT of each other (two frames of one point, turned apart, however far the
    body's origin lies from its lens), each on a branch that leads to one imager alone (None where they do not). A leaf with
    geometry fixed straight to that link, beside an optical frame (REP 103) or a frame the file declares a
    simulator sensor on, is the device's own housing piece (a camera's model frame, a lidar's cap): it belongs
    to the body too. Two optical frames (REP 103) whose lines of sight part by more than LINE_OF_SIGHT are two
    cameras, however close: a face carrying a camera looking ahead and one looking down."""
    body = fork_of(tree, [a, b])
    sight = (0.0, 0.0, 1.0)  # an optical frame's line of sight, its z axis (REP 103)
    if is_optical(tree, a) and is_optical(tree, b) \
            and dot(tree.direction_in(a, body, sight), tree.direction_in(b, body, sight)) < LINE_OF_SIGHT:
        return None
    one_point = math.dist(tree.position_in(a, body), tree.position_in(b, body)) <= VIEWPOINT
    housings = 0
    for leaf, other in ((a, b), (b, a)):
        path = tree.chain_to_root(leaf)
        branch = path[:path.index(body)]  # leaf ... the body's child
        if not branch or any(tree.edge_to(link).movable for link in branch):
            return None
        if not is_frame(tree, leaf) and len(branch) == 1 and (is_optical(tree, other) or declares_sensor(tree, other)):
            housings += 1
        elif not all(is_frame(tree, link) for link in branch):
            return None
        if any(_imagers_below(tree, link) > 1 for link in branch[1:]):
            return None
        if math.dist(tree.position_in(leaf, body), (0.0, 0.0, 0.0)) > CAMERA_BODY and not one_point:
            return None
    return body if housings < 2 else None


def declares_sensor(tree: KinematicTree, link: str) -> bool:
    """The file declares a simulator sensor on the link."""
    facts = tree.evidence.get(link)
    return facts is not None and bool(facts.sensors)


def _imagers_below(tree: KinematicTree, link: str) -> int:
    """How many imagers a branch link carries: its optical-convention leaves (REP 103), or all its leaves where
    none follows the convention. A link carrying two is a camera of its own (one of a stereo head's pairs).
    A link with one optical leaf of its own at its origin is that imager's frame: optical frames hung below it
    through frames of their own within BUILT_IN of it are its built-in sensors' (an inertial unit's below a colour
    frame), so it carries one; an eye hung below the other eye's frame lies a stereo baseline away."""
    leaves = [d for d in tree.descendants(link) if tree.is_leaf(d)]
    optical = [leaf for leaf in leaves if is_optical(tree, leaf)]
    own = [leaf for leaf in optical if tree.parent(leaf) == link]
    if len(own) == 1 and norm(tree.position_in(own[0], link)) <= VIEWPOINT \
            and all(norm(tree.position_in(leaf, link)) <= BUILT_IN for leaf in optical):
        return 1
    return len(optical) or len(leaves)


def frames_of_one_body(tree: KinematicTree, leaves: list[str]) -> list[list[str]]:
    """`leaves` partitioned into the frames of one body (body_of), each set in the order given."""
    return partition(leaves, lambda a, b: body_of(tree, a, b) is not None)


def viewpoints(tree: KinematicTree, leaves: list[str], cameras: Iterable[str] = ()) -> int | None:
    """How many places a device's frames see from: their positions at the zero pose, those within VIEWPOINT
    of each other counted once. Where some of the frames follow the optical convention (REP 103: z forward,
    along the x axis of the link they hang from), only those count (a camera's inertial frames see nothing),
    and two of them see from one place when they lie within VIEWPOINT across their line of sight.
    A lone link that is no optical frame stands for a camera written as one body, which shows no imager: one
    place where it is an eye of a pair (one of `cameras`, the cameras' links, is its twin: eye_pair, which no link
    is of itself), as many as the cameras the file declares on it see from where they see from two or more (a
    stereo pair declared as two cameras on one body), else None (unknown). A link a camera is declared on whose
    plugin writes its images in another of the frames (SimSensor.frame) is one imager with that frame, which stands
    for both (counted once, where that frame is)."""
    optical = [leaf for leaf in leaves if is_optical(tree, leaf)]
    if not optical and len(leaves) == 1:
        if any(eye_pair(tree, leaves[0], other) for other in cameras):
            return 1
        declared = _declared_places(tree, leaves[0])
        return declared if declared > 1 else None
    places: list[tuple[Vector, Vector | None]] = []  # a point, and the line of sight through it where known
    for leaf in [leaf for leaf in optical or leaves if not _written_elsewhere(tree, leaf, leaves)]:
        point = tree.position_in(leaf, tree.root)
        sight = unit(sub(tree.position_in(leaf, tree.root, (0.0, 0.0, 1.0)), point)) if optical else None
        if all(_apart(point, p, axis) > VIEWPOINT for p, axis in places):
            places.append((point, sight))
    return len(places)


def _written_elsewhere(tree: KinematicTree, link: str, frames: list[str]) -> bool:
    """Every camera declared on `link` writes its images in another of `frames`, one at least."""
    facts = tree.evidence.get(link)
    cameras = [s for s in (facts.sensors if facts else ()) if s.reference == link and s.places]
    return bool(cameras) and all(s.frame in frames and s.frame != link for s in cameras)


def _declared_places(tree: KinematicTree, link: str) -> int:
    """How many places the cameras declared on `link` see from (evidence.SimSensor.places), those within VIEWPOINT
    of each other counted once."""
    facts = tree.evidence.get(link)
    places: list[Vector] = []
    for point in (p for s in (facts.sensors if facts else ()) if s.reference == link for p in s.places):
        if all(math.dist(point, p) > VIEWPOINT for p in places):
            places.append(point)
    return len(places)


def eye_pair(tree: KinematicTree, a: str, b: str) -> bool:
    """Two camera bodies are the eyes of a stereo pair: on either side of the root's x-z plane (REP 103's left and
    right), further than MIRROR_EPS from it, each within MIRROR_EPS of the other's mirror image across it, and both
    look the same way (their x axes, parallel within OPTICAL_AXIS), side by side across that line of sight (further
    than VIEWPOINT apart). Cameras on the left and right of a robot look out to either side; a camera beside
    another of a kind at the centre has no mirror image."""
    pa, pb = tree.position_in(a, tree.root), tree.position_in(b, tree.root)
    sight = sub(tree.position_in(a, tree.root, (1.0, 0.0, 0.0)), pa)  # unit vectors: the frames' x axes
    other = sub(tree.position_in(b, tree.root, (1.0, 0.0, 0.0)), pb)
    return (abs(pa[1]) > MIRROR_EPS and math.dist((pa[0], -pa[1], pa[2]), pb) <= MIRROR_EPS
            and dot(sight, other) >= OPTICAL_AXIS and _apart(pb, pa, sight) > VIEWPOINT)


def mirrored(a: Vector, b: Vector, axis: int) -> bool:
    """Points `a` and `b` are each other's mirror image across the plane square to coordinate `axis` through the
    origin, within MIRROR_EPS."""
    return all(abs(a[k] + b[k] if k == axis else a[k] - b[k]) <= MIRROR_EPS for k in range(3))


def _apart(a: Vector, b: Vector, sight: Vector | None) -> float:
    """How far apart two frames see from: across `sight`, the line of sight through `b` (a frame further along
    it, as optical frames are often written a centimetre ahead of the lens, sees from the same place)."""
    gap = sub(a, b)
    if sight is None:
        return norm(gap)
    along = dot(gap, sight)
    return math.sqrt(max(dot(gap, gap) - along * along, 0.0))


def is_optical(tree: KinematicTree, leaf: str) -> bool:
    """The leaf follows the optical convention (REP 103): its z axis, the line of sight, along its parent's x axis."""
    parent = tree.parent(leaf)
    if parent is None:
        return False
    origin = tree.position_in(leaf, parent)
    z = tuple(p - o for p, o in zip(tree.position_in(leaf, parent, (0.0, 0.0, 1.0)), origin))
    return z[0] >= OPTICAL_AXIS


def optical_twins(tree: KinematicTree, a: str, b: str) -> bool:
    """One leaf is an optical frame (REP 103) and the other, fixed to the same link at the same point (within
    VIEWPOINT), looks along its line of sight with its x axis (within LINE_OF_SIGHT): one imager's body frame and
    optical frame written side by side (a `camera_depth_frame` beside its `camera_depth_optical_frame`)."""
    parent = tree.parent(a)
    if parent is None or tree.parent(b) != parent or any(tree.edge_to(x).movable for x in (a, b)) \
            or math.dist(tree.position_in(a, parent), tree.position_in(b, parent)) > VIEWPOINT:
        return False
    a_optical = is_optical(tree, a)
    if a_optical == is_optical(tree, b):
        return False
    optical, body = (a, b) if a_optical else (b, a)
    sight = tree.direction_in(optical, parent, (0.0, 0.0, 1.0))
    return dot(sight, tree.direction_in(body, parent, (1.0, 0.0, 0.0))) >= LINE_OF_SIGHT


LOOP_GAP = 0.001  # m: the two frames a closed kinematic loop is cut at coincide within this at the zero pose
LOOP_JOINTS = 2  # a loop that moves passes through this many joints besides its cut at least (a four-bar: three)


def loop_closures(tree: KinematicTree) -> frozenset[str]:
    """Leaf frames where a closed kinematic loop is cut to make a tree (a Stewart platform's rods, a linkage's
    bars): bare frames fixed to their links that coincide with another such frame at the zero pose, across
    LOOP_JOINTS joints that move or more (on the path between them). They mark a constraint for a solver, not a
    device; a camera's frame and its optical twin on one link coincide with nothing between them, and a jaw's tip
    and the fixed jaw's tip of a gripper written closed with one joint between them (a loop closed through one
    joint would hold it still)."""
    frames = [leaf for leaf in tree.leaves() if _fixed_frame(tree, leaf)]
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
                if a != b and math.dist(pa, pb) <= LOOP_GAP and _moving_between(tree, a, b) >= LOOP_JOINTS:
                    found.update((a, b))
    return frozenset(found)


def meeting_tips(tree: KinematicTree, leaf: str) -> list[str]:
    """The bare leaf frames fixed to their links that meet `leaf`, itself such a frame, at the zero pose (within
    LOOP_GAP) across fewer than LOOP_JOINTS joints that move, one at least: the tips of two jaws of a gripper written
    closed, the joint that opens it between them."""
    if not _fixed_frame(tree, leaf):
        return []
    point = tree.position_in(leaf, tree.root)
    return [other for other in tree.leaves() if other != leaf and _fixed_frame(tree, other)
            and math.dist(tree.position_in(other, tree.root), point) <= LOOP_GAP
            and 0 < _moving_between(tree, leaf, other) < LOOP_JOINTS]


def _fixed_frame(tree: KinematicTree, link: str) -> bool:
    """A bare frame (is_frame) fixed to a parent: where a loop is cut, or a jaw's tip."""
    return tree.parent(link) is not None and not tree.edge_to(link).movable and is_frame(tree, link)


def collision_volumes(tree: KinematicTree) -> frozenset[str]:
    """Leaves that only add to their parent's collision shape (a self-collision capsule): fixed at the origin of a
    parent that is a body (is_frame), with <collision> geometry and no <visual>. A device has a place of its own on
    the body it is mounted on; a link in the same place drawn for collision checking alone is more of that body
    (on a bare mount frame, it is the device itself)."""
    return frozenset(
        leaf for leaf in tree.leaves()
        if (edge := tree.parent_edge(leaf)) is not None and not edge.movable and norm(edge.origin.xyz) < SAME_PLACE
        and (facts := tree.evidence.get(leaf)) is not None and facts.collision_only and not is_frame(tree, edge.parent))


def _moving_between(tree: KinematicTree, a: str, b: str) -> int:
    """How many joints that move lie on the tree's path between links `a` and `b`."""
    meet = fork_of(tree, [a, b])
    return sum(tree.edge_to(link).movable for leaf in (a, b)
               for path in [tree.chain_to_root(leaf)] for link in path[:path.index(meet)])


def struts(tree: KinematicTree) -> frozenset[str]:
    """Leaves drawn alike (one primitive shape, the same meshes) a link lying at their mirror image across the root's
    x-z plane (REP 103's left and right, within MIRROR_EPS) that holds a drawn body up: one of a pair of standoffs
    or posts, the other carrying a plate or a deck, both pieces of structure."""
    drawn = {link for link in tree.links if (facts := tree.evidence.get(link)) is not None and not facts.is_pure_frame}
    at = {link: tree.position_in(link, tree.root) for link in drawn}
    holding = [link for link in drawn if any(child in drawn for child in tree.children(link))]
    return frozenset(leaf for leaf in tree.leaves() if leaf in drawn and abs(at[leaf][1]) > MIRROR_EPS
                     and any(drawn_alike(tree, leaf, other) and mirrored(at[leaf], at[other], 1) for other in holding))


def drawn_alike(tree: KinematicTree, a: str, b: str) -> bool:
    """Both links are drawn (a body, not a frame) with the same meshes or the same primitive."""
    fa, fb = tree.evidence.get(a), tree.evidence.get(b)
    return fa is not None and fb is not None and not fa.is_pure_frame and (fa.meshes, fa.shape) == (fb.meshes, fb.shape)


def rods(tree: KinematicTree) -> frozenset[str]:
    """Leaves whose body is a thin rod: a cylinder at least ROD_LENGTH times as long as it is thick and at most
    ROD_THICKNESS thick (a standoff, a pole, an antenna, a linkage's bar). A sensor's body holds its sensing element
    and electronics: none of the truth robots' or the parts library's sensors is so shaped (their rods are standoffs,
    antennas and bars)."""
    found = []
    for leaf in tree.leaves():
        facts = tree.evidence.get(leaf)
        size = facts.cylinder if facts is not None else None
        if size is not None and 0 < 2 * size[0] <= ROD_THICKNESS and size[1] >= ROD_LENGTH * 2 * size[0]:
            found.append(leaf)
    return frozenset(found)
