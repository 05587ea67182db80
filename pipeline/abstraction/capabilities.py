"""What each part can do, read from the URDF alone when a robot is populated (deterministic, no model).

- A sensor's *reference frames*: the links its measurements are expressed in. Its simulator declarations
  (pipeline.reading.evidence: those on its links whose type agrees with its class) name them: the plugin's
  frameName, else the link the declaration is attached to. A sensor without one is taken at the links of
  the sub-parts its class requires (ontologies/shapes.ttl: a camera's optical frames, another sensor's
  sensing elements), else at its leaf links.
- Its *specification*: each number its declarations state (rate, horizontal field of view, image size,
  rays, range, range resolution), where every declaration that states it states the same value (two
  imagers of different sizes state no one size); a number none states is None, never guessed.
- An arm's *degrees of freedom*: its joints that move on their own (no <mimic>).
- An arm's *reach*: the largest distance from where its first joint sits on its mount (that joint's
  origin) to its tool point (the tool centre point of the end-effector located on it, else the link its
  last joint moves) over its joint space within the URDF's limits (a continuous joint, or a revolute one
  without limits or with limits a full turn or more apart, over a full turn; a prismatic one without
  limits stays at 0; a joint with <mimic> follows its joint). The joint space is sampled: SAMPLES configurations drawn uniformly with a fixed
  seed, every corner of the limits (up to 2^MAX_CORNER_JOINTS of them) and the zero pose clamped into the
  limits; then a coordinate search from the best of them moves one joint at a time by a step starting
  at a quarter of its range, halved whenever no move improves, REFINEMENTS times (_JointSpace.largest).
  A sample can only fall short of the true largest distance, never exceed it. Limits so far apart that
  the arithmetic overflows (a prismatic joint within ±1e308) give a reach or opening that is not finite,
  which population leaves out.
- A gripper's *maximum opening*: how far two opposing fingertips (the deepest link of each finger chain,
  pipeline.abstraction.structure, that is a body rather than a frame) move apart between their closest and widest,
  over the same kind of sample of its finger joints; the widest pair where it has several.
- A head's *pan* and *tilt ranges*: the range (upper minus lower limit; a full turn for a continuous
  joint) of its first joint turning about the vertical, and of its first turning about the sideways
  axis, both read in the root's frame at the zero pose.
"""
from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np

from urdfkb.pipeline.abstraction.components import END_EFFECTOR, BodyPart, Component
from urdfkb.pipeline.reading.evidence import SimSensor
from urdfkb.pipeline.knowledge.ontology import Vocabulary
from urdfkb.pipeline.abstraction.frames import is_frame
from urdfkb.pipeline.abstraction.structure import tool_structure
from urdfkb.pipeline.reading.tree import Edge, KinematicTree, Vector, rotate_rpy

SAMPLES = 2048           # random configurations of a joint space
SEED = 31                # of the random generator: the same robot always gets the same sample
MAX_CORNER_JOINTS = 10   # every corner of the limits is tried for at most this many joints (1024 corners)
REFINEMENTS = 12         # halvings of the coordinate search's step
TOOL_POINT = "ToolCenterPoint"  # the sub-part class an arm's reach is measured to
AXIS_ALIGNED = math.cos(math.radians(20))  # a joint axis within 20 degrees of the vertical pans, of the sideways tilts


# --- sensors ---------------------------------------------------------------------------------------

@dataclass(frozen=True)
class SensorSpec:
    """What a sensor's declarations state (None: not stated, or stated differently by two of them)."""

    reference_frames: tuple[str, ...]
    rate: float | None = None          # Hz
    fov: float | None = None           # rad
    image: tuple[int, int] | None = None
    samples: int | None = None
    min_range: float | None = None     # m
    max_range: float | None = None     # m
    resolution: float | None = None    # m
    radiation: str | None = None       # what a ranging sensor emits ("ultrasound", "infrared")


def sensor_spec(tree: KinematicTree, vocab: Vocabulary, comp: Component) -> SensorSpec:
    """The reference frames and declared numbers of sensor `comp` (module docstring)."""
    declared = _declarations(tree, vocab, comp)
    named = [s.frame or s.reference for s in declared]
    numbers = {f: _agreed(getattr(s, f) for s in declared)
               for f in ("rate", "fov", "image", "samples", "min_range", "max_range", "resolution", "radiation")}
    return SensorSpec(tuple(dict.fromkeys(named)) or _own_frames(tree, vocab, comp), **numbers)


def _declarations(tree: KinematicTree, vocab: Vocabulary, comp: Component) -> list[SimSensor]:
    """The declarations on the sensor's links whose type agrees with its class, each once."""
    top = vocab.kinds[comp.kind].cls
    found = (s for link in comp.links if link in tree.evidence for s in tree.evidence[link].sensors)
    return [s for s in dict.fromkeys(found) if comp.cls not in vocab.disagreeing(vocab.declared_classes([s.type]), top)]


def _agreed(values: Iterable):
    """The one value all the stated ones agree on (floats to 4 decimals), else None."""
    stated = {round(v, 4) if isinstance(v, float) else v for v in values if v is not None}
    return stated.pop() if len(stated) == 1 else None


def _own_frames(tree: KinematicTree, vocab: Vocabulary, comp: Component) -> tuple[str, ...]:
    """The links of the sub-parts its class requires (the shapes': a camera's optical frames, another sensor's
    sensing elements, typed at the frames its measurements are expressed in), else its leaf links."""
    part = vocab.required_part(comp.cls)
    links = tuple(s.link for s in comp.subcomponents if part is not None and vocab.is_a(s.cls, part))
    return links or tuple(link for link in comp.links if tree.is_leaf(link))


# --- kinematics ------------------------------------------------------------------------------------

def degrees_of_freedom(tree: KinematicTree, joints: Iterable[str]) -> int:
    edges = _edges(tree)
    return sum(1 for j in joints if edges[j].independent)


def tool_point(tree: KinematicTree, vocab: Vocabulary, arm: BodyPart, components: Sequence[Component]) -> str | None:
    """The link an arm's reach is measured to: the tool centre point of an end-effector located on it below its
    last joint, else the link its last joint moves (None for an arm without joints)."""
    if not arm.joints:
        return None
    flange = _edges(tree)[arm.joints[-1]].child
    below = set(tree.descendants(flange)) | {flange}
    tcps = [s.link for c in components if c.kind == END_EFFECTOR and c.located_on == arm.name
            for s in c.subcomponents if TOOL_POINT in vocab and vocab.is_a(s.cls, TOOL_POINT) and s.link in below]
    return tcps[0] if tcps else flange


def reach(tree: KinematicTree, first_joint: str, tool: str) -> float | None:
    """The largest distance from `first_joint`'s origin to `tool`'s origin over the joint space of the joints
    between them (module docstring), None where `tool` does not hang below that joint."""
    start = _edges(tree)[first_joint]
    path = _path(tree, tool, start.parent)
    if path is None or start not in path:
        return None
    origin = np.array(start.origin.xyz)
    space = _JointSpace(tree, path)
    return space.largest(lambda q: np.linalg.norm(_positions(path, space.values(q)) - origin, axis=1))


def opening(tree: KinematicTree, links: Sequence[str]) -> float | None:
    """How far a gripper's two opposing fingertips move apart between their closest and widest (module
    docstring), the widest pair where it has several; None without opposing finger chains."""
    if len(links) < 2:
        return None
    tool = tool_structure(tree, list(links))
    tips = {f.name: _tip(tree, f.links) for f in tool.fingers}
    pairs = {tuple(sorted((f.name, o))) for f in tool.fingers for o in f.opposes}
    best = None
    for a, b in sorted(pairs):
        path_a, path_b = _path(tree, tips[a], tool.fork), _path(tree, tips[b], tool.fork)
        if path_a is None or path_b is None:
            continue
        space = _JointSpace(tree, path_a + path_b)

        def gap(q: np.ndarray) -> np.ndarray:
            values = space.values(q)
            return np.linalg.norm(_positions(path_a, values) - _positions(path_b, values), axis=1)

        span = space.largest(gap) + space.largest(lambda q: -gap(q))
        best = span if best is None else max(best, span)
    return best


def head_ranges(tree: KinematicTree, joints: Sequence[str]) -> tuple[float | None, float | None]:
    """(pan range, tilt range) in radians of a head with these joints (module docstring)."""
    edges = _edges(tree)
    found: dict[int, float] = {}
    for joint in joints:
        edge = edges[joint]
        if not edge.independent or edge.joint_type not in ("revolute", "continuous"):
            continue
        axis = _in_root(tree, edge.child, edge.axis)
        for index in (2, 1):  # z: pan, y: tilt
            if index not in found and abs(axis[index]) >= AXIS_ALIGNED:
                found[index] = _bounds(edge)[1] - _bounds(edge)[0]
    return found.get(2), found.get(1)


def _in_root(tree: KinematicTree, link: str, direction: Vector) -> Vector:
    end, start = tree.position_in(link, tree.root, direction), tree.position_in(link, tree.root)
    v = tuple(e - s for e, s in zip(end, start))
    norm = math.sqrt(sum(c * c for c in v)) or 1.0
    return (v[0] / norm, v[1] / norm, v[2] / norm)


def _tip(tree: KinematicTree, links: Sequence[str]) -> str:
    """The deepest link of a finger chain that is a body, else its deepest link."""
    bodies = [link for link in links if not is_frame(tree, link)] or list(links)
    return max(bodies, key=lambda link: len(tree.chain_to_root(link)))


def _edges(tree: KinematicTree) -> dict[str, Edge]:
    return {e.joint: e for e in tree.edges}


def _path(tree: KinematicTree, link: str, ancestor: str) -> list[Edge] | None:
    """The joints from `ancestor` down to `link`, root-most first; None where `ancestor` is not above `link`."""
    chain = tree.chain_to_root(link)
    if ancestor not in chain:
        return None
    return [tree.edge_to(child) for child in reversed(chain[:chain.index(ancestor)])]


def _positions(path: list[Edge], values: dict[str, np.ndarray]) -> np.ndarray:
    """The origin of the last link of `path` in the frame of its first joint's parent, per configuration:
    (N, 3). Joints absent from `values` stay at zero."""
    count = len(next(iter(values.values()))) if values else 1
    point = np.zeros((count, 3))
    for edge in reversed(path):
        q = values.get(edge.joint)
        if q is not None and edge.joint_type in ("revolute", "continuous"):
            point = _turned(point, _unit(edge.axis), q)
        elif q is not None and edge.joint_type == "prismatic":
            point = point + q[:, None] * _unit(edge.axis)
        point = point @ _rotation(edge.origin.rpy).T + np.array(edge.origin.xyz)
    return point


def _turned(points: np.ndarray, axis: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """Rodrigues' rotation of each point about the unit `axis` by its angle."""
    cos, sin = np.cos(angles)[:, None], np.sin(angles)[:, None]
    return points * cos + np.cross(axis, points) * sin + np.outer(points @ axis, axis) * (1 - cos)


def _rotation(rpy: Vector) -> np.ndarray:
    return np.array([rotate_rpy(rpy, basis) for basis in ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))]).T


def _unit(axis: Vector) -> np.ndarray:
    v = np.array(axis, dtype=float)
    norm = np.linalg.norm(v)
    return v / norm if norm > 0 else np.array([1.0, 0.0, 0.0])


def _bounds(edge: Edge) -> tuple[float, float]:
    """Where a joint may go: its limits (those of a continuous joint its file bounds too: Edge.bounded); a full
    turn for another continuous joint or a revolute one without limits; nowhere (0) for a prismatic one without
    limits."""
    if (edge.joint_type == "continuous" and not edge.bounded) or (edge.limits is None and edge.joint_type == "revolute"):
        return (-math.pi, math.pi)
    if edge.limits is None or edge.joint_type not in ("revolute", "prismatic", "continuous"):
        return (0.0, 0.0)
    return (min(edge.limits), max(edge.limits))


def _sampled(edge: Edge) -> tuple[float, float]:
    """Where the joint space samples a joint: its bounds, a full turn for a revolute joint whose limits are a full
    turn or more apart (the same poses, at angles that stay exact where the limits are ±1e308)."""
    low, high = _bounds(edge)
    return (-math.pi, math.pi) if edge.joint_type == "revolute" and high - low >= 2 * math.pi else (low, high)


class _JointSpace:
    """The joints that move on their own among (or behind the <mimic> of) a path's joints, with their bounds:
    configurations are arrays (N, joints)."""

    def __init__(self, tree: KinematicTree, path: Iterable[Edge]):
        self.edges = _edges(tree)
        self.moving = [e for e in dict.fromkeys(path) if e.movable and e.joint_type in ("revolute", "continuous", "prismatic")]
        free: dict[str, None] = {}
        for edge in self.moving:
            source = self._source(edge)
            if source is not None:
                free.setdefault(source.joint)
        self.free = list(free)
        bounds = np.array([_sampled(self.edges[j]) for j in self.free]).reshape(-1, 2)
        self.low, self.high = bounds[:, 0], bounds[:, 1]

    def _source(self, edge: Edge) -> Edge | None:
        """The joint `edge` follows through <mimic> (itself where it follows none); None for a broken chain."""
        seen = set()
        while edge.mimic is not None:
            if edge.joint in seen or edge.mimic not in self.edges:
                return None
            seen.add(edge.joint)
            edge = self.edges[edge.mimic]
        return edge

    def values(self, q: np.ndarray) -> dict[str, np.ndarray]:
        """Each moving joint's position per configuration, a joint with <mimic> following its joint."""
        column = {j: q[:, i] for i, j in enumerate(self.free)}

        def value(edge: Edge) -> np.ndarray:
            if edge.mimic is None:
                return column.get(edge.joint, np.zeros(len(q)))
            if edge.mimic not in self.edges or self._source(edge) is None:
                return np.zeros(len(q))
            return edge.mimic_multiplier * value(self.edges[edge.mimic]) + edge.mimic_offset

        return {e.joint: value(e) for e in self.moving}

    def sample(self) -> np.ndarray:
        """SAMPLES uniform configurations (fixed seed), the corners of the limits and the zero pose clamped."""
        n = len(self.free)
        rng = np.random.default_rng(SEED)
        drawn = self.low + rng.random((SAMPLES, n)) * (self.high - self.low)
        parts = [drawn, np.clip(np.zeros((1, n)), self.low, self.high)]
        if n <= MAX_CORNER_JOINTS:
            corners = np.array(np.meshgrid(*[(lo, hi) for lo, hi in zip(self.low, self.high)], indexing="ij"))
            parts.append(corners.reshape(n, -1).T)
        return np.vstack(parts)

    def largest(self, f) -> float:
        """The largest value of `f` (configurations → values) over the sample, refined by a coordinate search:
        each round moves the best configuration by ± the step along each joint (clipped into its limits) and
        keeps the best move if it is better, else halves the step; REFINEMENTS halvings end it."""
        with np.errstate(over="ignore", invalid="ignore"):  # an overflow's inf or NaN is the caller's to refuse
            return self._largest(f)

    def _largest(self, f) -> float:
        if not self.free:
            return float(np.max(f(np.zeros((1, 0)))))
        q = self.sample()
        scores = f(q)
        best, score = q[int(np.argmax(scores))], float(np.max(scores))
        step, halvings = (self.high - self.low) / 4, 0
        while halvings < REFINEMENTS:
            moves = np.clip(np.vstack([best + np.diag(step), best - np.diag(step)]), self.low, self.high)
            values = f(moves)
            if float(np.max(values)) > score + 1e-12:
                best, score = moves[int(np.argmax(values))], float(np.max(values))
            else:
                step, halvings = step / 2, halvings + 1
        return score
