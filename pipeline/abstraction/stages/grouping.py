"""Stage 4, group merging: partition the classified sub-chains into physical devices.

Sensors: the model names each sub-chain's device, picking among the beginnings of the leaf's own
name (a URDF identifier, so the answer set is finite and checkable) the part that names the whole
device ("chest_rgbd" for "chest_rgbd_depth_optical_frame"). A beginning that is also a beginning of
the mount's name ("chest" under "chest_link") names the body part the device sits on, not the device,
and is not offered. Sub-chains near each other in the
tree (sharing links, or on the same mount), with the same device name and pre-classes in the same
sensor category (the taxonomy level under Sensor: RGB and depth frames are both vision; a button and
an accelerometer on one palm are not) form one device. Two sub-chains that share only their mount,
each with a body of its own (its first link with geometry, the housing, or failing one the device's own bare
frame that its frames hang from), are near only if the two housings face the same way and lie within DEVICE_SPAN of each other: housings pointing apart or far apart are separate devices
whatever their names share, while a stereo pair's two housings look the same way side by side; a bare frame on the
mount is near another sub-chain only within BARE_SPAN of its leaf. Two camera frames fixed
bare and straight on the mount join only if they look the same way (_looking_alike: a camera looking ahead and one
looking down are two). A sub-chain with no such neighbour is a device of its own whatever its name, so it is not asked.
End-effectors: sub-chains whose leaves meet (their lowest common ancestor) inside one of them, or
at the mount they share, are parts of the one tool at that arm end, whatever its fingers are called;
the tool's provisional mount is the deepest mount the model named for any of its chains that carries
them all (stages.tools then settles extent and mount from structure).
One body, one device: two sensor sub-chains of one category whose leaves are frames (no geometry) hanging
by fixed joints from one link inside both (the device's body, a housing or a bare camera frame), within
CAMERA_BODY of it or at one point (frames.body_of), each by a branch of that link that leads to one imager alone, are one device whatever their
names: the colour, depth, infrared and inertial frames of an RGB-D camera, which the name question
split into one device per frame; one device name is asked for them all. A frame of the body binds to one
called a vision sensor whatever category its own pre-class falls in: the camera's own inertial frames belong
to the camera (ontology.md). A housing piece fixed straight to that
link beside an optical frame (a camera's model frame) is bound with them. A branch that carries several
imagers is a camera of its own (a stereo head's wide and narrow pairs on one bar), so it binds nothing there;
its own frames bind below it (frames.body_of). The body may also be the bare frame the sub-chains are all mounted on
where a joint moves it and it is a camera's own (its optical frames see from one place, beside one housing at
most: a camera on its tilt motor), or such a housing that the file declares a camera on, carrying bare frames
alone: the mount cannot be raised above the motion.
One declaration, one device, for rangers and transducers: two sub-chains each declaring a ray sensor, a depth camera
or a force-torque sensor of its own (no declaration in common) are two devices whatever their names or their body (a
robot's infrared floor sensors, each with its own range plugin; a sensor head's time-of-flight cameras, each with its
own depth image; a foot's front and rear force-torque sensors).
One place, one device: a bare frame fixed where a link of a near sub-chain of its category is, turned as it is, on the
same parent (and of no other sub-chain), is another name for that link (_aliases: a driver's `velodyne` frame beside
the lidar's own base).
One product, one device: two near sub-chains of one category whose links name one catalogue product, one of them a
lone drawn leaf declaring nothing (a camera's bracket drawn with the product's mesh), are one device (_one_product);
on one mount they are near where their bodies lie within DEVICE_SPAN, whichever way the piece is turned
(_piece_beside).
Two products, two devices: two sub-chains whose links name catalogue products of two classes are never one device
(_two_products: a depth camera and a tracking camera bolted to one sensor head), whatever their names or their body.
One declaration, one device: two near sub-chains of one category are one device where a simulator sensor declared on
a link of one gives its data in a frame of the other (its plugin's frameName: the right camera of a stereo pair
publishing in the left camera's optical frame), or declares several cameras at once (SDF's multicamera), or gives
colour and depth images while the other, bare frames declaring nothing, ends within IMAGER_SPAN of it looking the
same way (_imager_beside: a Kinect's colour frames beside the depth frames its declaration is written on), whatever
their names.
Each sub-chain lands in exactly one group: a partition by construction.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass, field

from urdfkb.pipeline.abstraction.components import END_EFFECTOR
from urdfkb.pipeline.abstraction.oracle import Oracle
from urdfkb.pipeline.abstraction.prompts import device_name_question
from urdfkb.pipeline.abstraction.stages.asking import Progress, ask
from urdfkb.pipeline.abstraction.stages.attachment import SubChain, sub_chain
from urdfkb.pipeline.abstraction.alike import partition
from urdfkb.pipeline.abstraction.frames import (SAME_PLACE, body_of, declares_sensor, is_frame, is_optical,
                                                optical_twins, viewpoints)
from urdfkb.pipeline.abstraction.catalogue import Product
from urdfkb.pipeline.abstraction.stages.identification import named_product
from urdfkb.pipeline.reading.evidence import SimSensor
from urdfkb.pipeline.reading.tree import KinematicTree, Vector, fork_of
from urdfkb.pipeline.abstraction.vectors import dot, sub

_WORD_BREAK = re.compile(r"(?=[_/])|(?<=[a-z0-9])(?=[A-Z])")  # a namespace's "/" parts words too (multisense/gyro)
ALIKE = math.cos(math.radians(25))  # two frames face the same way: each axis within 25 degrees
VISION = "VisionSensor"  # the ontology's category of cameras, whose bodies carry frames of other categories
AUDIO = "AudioSensor"  # a microphone hears the room, not the camera: never a camera's built-in frame
INERTIAL = "InertialSensor"  # the category of those a camera carries built in (its IMU's frames)
DEVICE_SPAN = 0.25  # m: the widest two housings of one device lie apart (a wide stereo baseline)
BARE_SPAN = 2 * DEVICE_SPAN  # m: the farthest a device's bare frame on its mount lies from its other frames
IMAGER_SPAN = 0.06  # m: an RGB-D camera's colour and depth imagers lie this close (Kinect: 2.5 cm, Kinect v2: 5)
SAME_TURN = 1e-9  # 1 - cosine: two frames whose axes agree this closely are turned alike
MULTI_CAMERA = "multicamera"  # SDF's sensor type of several cameras declared as one
DEPTH_IMAGES = ("depth", "depth_camera", "rgbd_camera")  # SDF's (and Gazebo classic's) types of a depth camera
IMAGES = ("camera", MULTI_CAMERA, *DEPTH_IMAGES)  # the types of those that give images
ONE_EACH = (*DEPTH_IMAGES, "force_torque")  # besides ray sensors, types each declaration of which is one device


@dataclass
class Group:
    """Sub-chains judged to be one device, plus links absorbed by verification."""

    chains: list[SubChain]
    absorbed: list[str] = field(default_factory=list)

    @property
    def members(self) -> list[str]:
        """Every link of the device (the root excluded), in a stable order."""
        seen = dict.fromkeys(link for c in self.chains for link in c.links)
        seen.update(dict.fromkeys(self.absorbed))
        return list(seen)

    @property
    def leaves(self) -> list[str]:
        return [c.leaf for c in self.chains]


def name_prefixes(name: str) -> tuple[str, ...]:
    """Every beginning of `name` that ends at a word break ('_', '/' or a lower→upper case change), and the name."""
    cuts = [m.start() for m in _WORD_BREAK.finditer(name) if m.start() > 0]
    return tuple(dict.fromkeys([name[:c] for c in cuts] + [name]))


def device_names(chain: SubChain) -> tuple[str, ...]:
    """The device names offered for a sensor sub-chain: beginnings of its leaf's name that do not
    also begin its mount's name (the leaf's full name is always offered)."""
    place = set(name_prefixes(chain.root))
    return tuple(p for p in name_prefixes(chain.leaf) if p not in place or p == chain.leaf)


def _near(tree: KinematicTree, a: SubChain, b: SubChain) -> bool:
    """The two sub-chains could be one device's: they share a link or a mount, and where each has a body of its own
    (below where they part: two cameras on one rack) those bodies lie side by side (_side_by_side); on one mount,
    where one is a bare frame, their leaves lie within BARE_SPAN (a vehicle's front and rear scanners, each a drawn
    body with a bare frame beside it, are two)."""
    if set(a.links) & set(b.links) or a.root in b.links or b.root in a.links:
        fork = fork_of(tree, [a.leaf, b.leaf])
        own_a, own_b = _own_body(tree, a, fork), _own_body(tree, b, fork)
        return own_a is None or own_b is None or _side_by_side(tree, fork, own_a, own_b)
    if a.root != b.root:
        return False
    housing_a, housing_b = _housing(tree, a), _housing(tree, b)
    if housing_a is None or housing_b is None:  # a bare frame: near where it lies within a device of the other
        return not _bare_apart(tree, a, b)
    return _side_by_side(tree, a.root, housing_a, housing_b)


def _bare_apart(tree: KinematicTree, a: SubChain, b: SubChain) -> bool:
    """The two sub-chains' leaves, on one mount, lie farther apart than BARE_SPAN."""
    return math.dist(tree.position_in(a.leaf, a.root), tree.position_in(b.leaf, b.root)) > BARE_SPAN


def _own_body(tree: KinematicTree, chain: SubChain, fork: str) -> str | None:
    """The first link with geometry on `chain` below `fork`, where it parts from another sub-chain."""
    return _first_drawn(tree, chain.links[chain.links.index(fork) + 1:] if fork in chain.links else chain.links)


def _first_drawn(tree: KinematicTree, links: tuple[str, ...]) -> str | None:
    """The first of `links` with geometry (a body, not a frame)."""
    return next((link for link in links if link in tree.evidence and not is_frame(tree, link)), None)


def _bare_cameras_apart(tree: KinematicTree, a: SubChain, b: SubChain) -> bool:
    """Two camera frames, each bare and fixed straight on the one mount (no housing), do not look the same way
    (_looking_alike): two cameras, whatever their names share."""
    return a.root == b.root and len(a.links) == len(b.links) == 1 and _housing(tree, a) is None \
        and _housing(tree, b) is None and not _looking_alike(tree, a.root, a.leaf, b.leaf)


def _housing(tree: KinematicTree, chain: SubChain) -> str | None:
    """The sub-chain's first link with geometry: its body, where it has one; else its first link below the mount
    when that is not the leaf: the device's own bare frame, which its other frames hang from."""
    body = _first_drawn(tree, chain.links)
    own = chain.links[0] if len(chain.links) > 1 else None  # links run from the mount's child down to the leaf
    return body or own


def _side_by_side(tree: KinematicTree, mount: str, a: str, b: str) -> bool:
    """Links `a` and `b`, at the zero pose in their mount's frame, lie within DEVICE_SPAN and face the
    same way (the same x and z axes)."""
    (xa, _, za), (xb, _, zb) = _axes(tree, a, mount), _axes(tree, b, mount)
    near = math.dist(tree.position_in(a, mount), tree.position_in(b, mount)) <= DEVICE_SPAN
    return near and dot(xa, xb) >= ALIKE and dot(za, zb) >= ALIKE


def _axes(tree: KinematicTree, link: str, mount: str) -> tuple[Vector, Vector, Vector]:
    """The link's x, y and z axes in `mount`'s frame at the zero pose."""
    origin = tree.position_in(link, mount)
    x, y, z = (sub(tree.position_in(link, mount, unit), origin)
               for unit in ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)))
    return x, y, z


def _looking_alike(tree: KinematicTree, mount: str, a: str, b: str) -> bool:
    """Two frames look the same way from `mount`: their x and z axes alike (within ALIKE), or one is a camera's own
    frame (x forward, z up) and the other its optical frame (REP 103: z forward, y down), however it is tilted."""
    def optical_of(own: tuple[Vector, Vector, Vector], optical: tuple[Vector, Vector, Vector]) -> bool:
        return dot(own[0], optical[2]) >= ALIKE and dot(own[2], optical[1]) <= -ALIKE
    first, second = _axes(tree, a, mount), _axes(tree, b, mount)
    same = dot(first[0], second[0]) >= ALIKE and dot(first[2], second[2]) >= ALIKE
    return same or optical_of(first, second) or optical_of(second, first)


def _one_body(tree: KinematicTree, a: SubChain, b: SubChain) -> bool:
    """The two leaves are frames of one body (frames.body_of) that lies inside both sub-chains, or that both are
    mounted on where it is a camera's own frame on a motor (_tilting_camera), which one_mount cannot raise above the
    joint."""
    body = body_of(tree, a.leaf, b.leaf)
    if body is None:
        return False
    return (body in a.links and body in b.links) or (body == a.root == b.root and _tilting_camera(tree, body))


def _tilting_camera(tree: KinematicTree, frame: str) -> bool:
    """`frame` is a camera's own frame moved by a joint (a tilt motor): bare, with every optical frame below it
    seeing from one place (frames.viewpoints) and at most one body with geometry hung from it, the housing; or the
    housing itself, a body on which the file declares a camera (_declares_camera), carrying bare frames alone. A bare
    pan-tilt or head frame carrying two cameras, or eyes and an inertial unit, sees from more places."""
    if tree.parent(frame) is None or not tree.edge_to(frame).movable:
        return False
    leaves = [leaf for leaf in tree.descendants(frame) if tree.is_leaf(leaf)]
    if not is_frame(tree, frame):
        return _declares_camera(tree, frame) and all(is_frame(tree, leaf) for leaf in leaves)
    optical = [leaf for leaf in leaves if is_optical(tree, leaf)]
    return bool(optical) and viewpoints(tree, optical) == 1 and sum(not is_frame(tree, leaf) for leaf in leaves) <= 1 \
        and all(leaf in optical or not is_frame(tree, leaf) for leaf in leaves)


def _declares_camera(tree: KinematicTree, link: str) -> bool:
    """The file declares on `link` itself a simulator sensor that gives images (a camera, a depth camera)."""
    facts = tree.evidence.get(link)
    return facts is not None and any(s.reference == link and (s.places or s.type in IMAGES) for s in facts.sensors)


def _declared_together(tree: KinematicTree, a: SubChain, b: SubChain) -> bool:
    """A simulator sensor declared on a link of one sub-chain gives its data in a frame of the other (its plugin's
    frameName): one device whose imagers share a frame, as the right camera of a stereo pair publishes in the left
    camera's optical frame; or one of them carries a declaration of several cameras at once (SDF's `multicamera`,
    a stereo head's), whose other imager is its near neighbour's."""
    return any(s.frame in y.links or s.type == MULTI_CAMERA for x, y in ((a, b), (b, a)) for s in _declared_on(tree, x))


def _declared_on(tree: KinematicTree, x: SubChain) -> list[SimSensor]:
    """The simulator sensors declared on the sub-chain's links."""
    return [s for link in x.links if link in tree.evidence for s in tree.evidence[link].sensors
            if s.reference in x.links]


def _imager_beside(tree: KinematicTree, a: SubChain, b: SubChain) -> bool:
    """`a` declares on its links a camera giving colour and depth images (one RGB-D device), and `b`, bare frames
    declaring nothing, ends within IMAGER_SPAN of `a`'s leaf looking the same way: the device's other imager."""
    if not any(s.colour and s.depth for s in _declared_on(tree, a)) or _declared_on(tree, b) \
            or not all(is_frame(tree, x) for x in b.links):
        return False
    fork = fork_of(tree, [a.leaf, b.leaf])
    return math.dist(tree.position_in(a.leaf, fork), tree.position_in(b.leaf, fork)) <= IMAGER_SPAN \
        and _looking_alike(tree, fork, a.leaf, b.leaf)


def _one_product(tree: KinematicTree, a: SubChain, b: SubChain, named_a: Product | None,
                 named_b: Product | None) -> bool:
    """Two near sub-chains whose links name one catalogue product (`named_a`, `named_b`: named_product of each), one
    of them a lone drawn leaf declaring no sensor (a piece: the bracket a camera is mounted with, drawn with the
    product's mesh), are one device."""
    def piece(x: SubChain) -> bool:
        facts = tree.evidence.get(x.leaf)
        return len(x.links) == 1 and not is_frame(tree, x.leaf) and not (facts is not None and facts.sensors)
    return (piece(a) or piece(b)) and named_a is not None and named_a == named_b


def _piece_beside(tree: KinematicTree, a: SubChain, b: SubChain, named_a: Product | None,
                  named_b: Product | None) -> bool:
    """Two sub-chains on one mount naming one product, one of them a piece of it (_one_product), their bodies within
    DEVICE_SPAN: near whichever way the piece's frame is turned (a bracket's mesh exported on its side)."""
    if a.root != b.root or not _one_product(tree, a, b, named_a, named_b):
        return False
    housing_a, housing_b = _housing(tree, a), _housing(tree, b)
    return housing_a is not None and housing_b is not None \
        and math.dist(tree.position_in(housing_a, a.root), tree.position_in(housing_b, a.root)) <= DEVICE_SPAN


def _aliases(tree: KinematicTree, chains: list[SubChain]) -> set[tuple[int, int]]:
    """The pairs of sub-chains (both ways) where the leaf of one is a bare frame fixed where a link of the other, and
    of no third, is fixed on the same parent, turned as it is: another name for that link (a driver's frame written
    beside a lidar's own base)."""
    found: set[tuple[int, int]] = set()
    for i, a in enumerate(chains):
        if not is_frame(tree, a.leaf):
            continue
        twins = [j for j, b in enumerate(chains)
                 if j != i and any(link != a.leaf and _coincident(tree, a.leaf, link) for link in b.links)]
        if len(twins) == 1:
            found |= {(i, twins[0]), (twins[0], i)}
    return found


def _coincident(tree: KinematicTree, a: str, b: str) -> bool:
    """Links `a` and `b` are fixed to one parent at one place, turned alike."""
    edge_a, edge_b = tree.parent_edge(a), tree.parent_edge(b)
    if edge_a is None or edge_b is None or edge_a.movable or edge_b.movable or edge_a.parent != edge_b.parent:
        return False
    axes = zip(_axes(tree, a, edge_a.parent), _axes(tree, b, edge_a.parent))
    return math.dist(edge_a.origin.xyz, edge_b.origin.xyz) < SAME_PLACE and all(dot(u, v) >= 1.0 - SAME_TURN
                                                                                for u, v in axes)


def _two_declared(tree: KinematicTree, a: SubChain, b: SubChain) -> bool:
    """Each of the two sub-chains declares a sensor that is a device of its own (_declared_devices), none in common."""
    shared = set(a.links) & set(b.links)  # one chain may hang below the other's sensor
    own_a, own_b = _declared_devices(tree, a, shared), _declared_devices(tree, b, shared)
    return bool(own_a and own_b and own_a.isdisjoint(own_b))


def _two_products(a: Product | None, b: Product | None) -> bool:
    """Both sub-chains name a catalogue product, of two classes: two devices (one product's frames name it alike)."""
    return a is not None and b is not None and a.cls != b.cls


def _declared_devices(tree: KinematicTree, chain: SubChain, shared: set[str]) -> frozenset[SimSensor]:
    """The ray, depth and force-torque sensors declared on the sub-chain's links below its mount, but those `shared`
    with another sub-chain: each is one device (one scan, range reading, depth image, or one six-axis transducer),
    so two sub-chains each declaring its own are two devices, even where one hangs below the other (a camera's frames
    written as a chain of calibrations)."""
    return frozenset(s for link in chain.links if link in tree.evidence and link not in shared
                     for s in tree.evidence[link].sensors if s.ranging or s.type in ONE_EACH)


def _built_in(tree: KinematicTree, a: SubChain, b: SubChain, categories: dict[str, str], apart: frozenset[str]) -> bool:
    """The two leaves are frames of one body and one of them was called a vision sensor: the other is the camera's
    own inertial, magnetic or temperature frame, or its model frame, which belongs to the camera whatever it
    measures (ontology.md: a camera's own inertial frames belong to it), unless the file declares on it a sensor of
    its own that no camera carries (`apart`: a sonar beside a downward camera) or it was called a microphone (AUDIO:
    a sensor head's microphone beside its cameras)."""
    return VISION in (categories[a.leaf], categories[b.leaf]) and AUDIO not in (categories[a.leaf], categories[b.leaf]) \
        and not {a.leaf, b.leaf} & apart and _one_body(tree, a, b)


def _housing_piece(tree: KinematicTree, a: SubChain, b: SubChain) -> bool:
    """One leaf is a drawn piece declaring nothing, the other a frame the file declares a sensor on or an optical
    frame, and both hang from one body (frames.body_of: the piece fixed straight to it): the piece is the device's own
    housing (a lidar's cap), whatever kind of sensor the model took it for."""
    return any(not is_frame(tree, x.leaf) and not declares_sensor(tree, x.leaf)
               and (declares_sensor(tree, y.leaf) or is_optical(tree, y.leaf)) for x, y in ((a, b), (b, a))) \
        and _one_body(tree, a, b)


def one_mount(tree: KinematicTree, chains: list[SubChain]) -> list[SubChain]:
    """Frames of one body (frames.body_of) that the model mounted apart, some on a link above the body and some on
    the body or below it, all mounted on the highest of those mounts above the body: the body is then
    inside every chain, and group merging binds them into one device. Where the model mounted them all on the body
    or below it and the body is fixed to its parent and is the device's own (_devices_own: a camera's bare
    `camera_link` with colour, depth and infrared frames below it, or a housing carrying nothing but such frames),
    they are mounted on its parent."""
    out = {c.leaf: c for c in chains}
    bodies = [(a.leaf, b.leaf, body) for i, a in enumerate(chains) for b in chains[:i]
              if (body := body_of(tree, a.leaf, b.leaf)) is not None]
    moved = True
    while moved:  # each move only raises a mount: this ends
        moved = False
        for a, b, body in bodies:
            above = tree.chain_to_root(body)[1:]
            mounts = [out[leaf].root for leaf in (a, b) if out[leaf].root in above]
            if mounts and out[a].root != out[b].root:
                top = max(mounts, key=above.index)
                out[a], out[b] = sub_chain(tree, a, top), sub_chain(tree, b, top)
                moved = True
    for body in dict.fromkeys(body for _, _, body in bodies):  # the device's own body its frames all hang from
        bound = {leaf for a, b, on in bodies if on == body for leaf in (a, b)}
        if _devices_own(tree, body, bound) and tree.parent(body) is not None and not tree.edge_to(body).movable \
                and all(body in tree.chain_to_root(out[leaf].root) for leaf in bound):
            out.update((leaf, sub_chain(tree, leaf, tree.parent(body))) for leaf in bound)  # type: ignore[arg-type]
    return [out[c.leaf] for c in chains]


def _devices_own(tree: KinematicTree, body: str, frames: set[str]) -> bool:
    """The body that `frames` hang from is their device's own: a bare frame (a camera's `camera_link`), or a housing
    with geometry that carries nothing but them (a tracking camera's body with its two fisheye and inertial frames);
    a body carrying anything else (a head with a lidar beside its cameras) is where devices are mounted."""
    return is_frame(tree, body) or all(leaf in frames for leaf in tree.descendants(body) if tree.is_leaf(leaf))


def _meet_inside(tree: KinematicTree, a: SubChain, b: SubChain) -> bool:
    meet = fork_of(tree, [a.leaf, b.leaf])
    return meet in a.links or meet in b.links or meet == a.root == b.root


def merge(oracle: Oracle, tree: KinematicTree, chains: list[SubChain], kind: str, categories: dict[str, str],
          progress: Progress | None = None, apart: frozenset[str] = frozenset()) -> list[Group]:
    """Partition `chains` into devices (see the module docstring); `categories`: leaf → sensor category; `apart`:
    leaves declared as sensors of their own that no camera carries (never a camera's built-in frame)."""
    products = [named_product(tree, list(reversed(c.links))) if kind != END_EFFECTOR else None for c in chains]
    two = [[kind != END_EFFECTOR and i != j and (_two_declared(tree, a, b) or _two_products(products[i], products[j]))
            for j, b in enumerate(chains)]
           for i, a in enumerate(chains)]

    def two_devices(i: int, j: int) -> bool:
        return two[i][j]
    if kind == END_EFFECTOR:
        same = [[_meet_inside(tree, a, b) for b in chains] for a in chains]
    else:
        could = [[i != j and (categories[a.leaf] == categories[b.leaf] or _built_in(tree, a, b, categories, apart)
                              or _housing_piece(tree, a, b))
                  and not two_devices(i, j)
                  and (_near(tree, a, b) or _piece_beside(tree, a, b, products[i], products[j]))
                  and not (categories[a.leaf] == categories[b.leaf] == VISION and _bare_cameras_apart(tree, a, b))
                  for j, b in enumerate(chains)]
                 for i, a in enumerate(chains)]
        aliases = _aliases(tree, chains)
        bound = [[could[i][j] and (_one_body(tree, a, b) or _declared_together(tree, a, b) or (i, j) in aliases
                                   or _imager_beside(tree, a, b) or _imager_beside(tree, b, a)
                                   or _one_product(tree, a, b, products[i], products[j])
                                   or optical_twins(tree, a.leaf, b.leaf))
                  for j, b in enumerate(chains)]
                 for i, a in enumerate(chains)]
        joinable = [any(c and not b for c, b in zip(row_c, row_b)) for row_c, row_b in zip(could, bound)]
        device = _device_names(oracle, chains, joinable,
                               partition(range(len(chains)), lambda i, j: bound[i][j], two_devices), progress)
        same = [[bound[i][j] or (could[i][j] and device[i] == device[j]) for j in range(len(chains))]
                for i in range(len(chains))]
    groups = [Group([chains[i] for i in members])
              for members in partition(range(len(chains)), lambda i, j: same[i][j], two_devices)]
    if kind == END_EFFECTOR:
        for group in groups:
            group.chains = _one_mount(tree, group.chains)
    return groups


def _device_names(oracle: Oracle, chains: list[SubChain], joinable: list[bool], devices: list[list[int]],
                  progress: Progress | None) -> list[str]:
    """Each sub-chain's device name as the model gives it. Only a chain that could join another (one
    near it, of its category) is asked: for the others no answer changes the partition, so their own
    leaf name stands. The chains of one device by structure (`devices`, frames of one body) are one device,
    so the first that could join another is asked for all of them."""
    names = [c.leaf for c in chains]
    asked = [(members, first) for members in devices
             if (first := next((i for i in members if joinable[i]), None)) is not None]
    verdicts = ask(oracle, [device_name_question(chains[i].leaf, device_names(chains[i])) for _, i in asked],
                   "group merging", progress)
    for (members, first), verdict in zip(asked, verdicts):
        for j in members:
            names[j] = verdict.answer or chains[first].leaf
    return names


def _one_mount(tree: KinematicTree, chains: list[SubChain]) -> list[SubChain]:
    """Re-mount a tool's chains on the deepest named mount that is an ancestor of every leaf."""
    carrying = [c.root for c in chains if all(c.root in tree.chain_to_root(x.leaf)[1:] for x in chains)]
    if not carrying:
        return chains
    mount = max(carrying, key=lambda r: len(tree.chain_to_root(r)))
    return [sub_chain(tree, c.leaf, mount) for c in chains]
