"""The kinematic tree of a robot: links joined by joints, one root, no cycles."""
from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import asdict, dataclass, field
from math import pi

from urdfkb.pipeline.errors import URDFError
from urdfkb.pipeline.reading.evidence import LinkEvidence
from urdfkb.pipeline.reading.rotation import rotate_rpy

JOINT_TYPES = ("fixed", "revolute", "continuous", "prismatic", "floating", "planar")

Vector = tuple[float, float, float]


@dataclass(frozen=True)
class Origin:
    """A joint origin: the child frame's pose in the parent frame (URDF xyz and rpy)."""

    xyz: Vector
    rpy: Vector


@dataclass(frozen=True)
class Edge:
    """One joint of the tree, from its parent link to its child link, with what the URDF says of its motion.

    `axis` is in the joint (child) frame, (1, 0, 0) where the URDF gives none; `limits` is (lower, upper)
    where a <limit> gives them, `velocity` and `effort` its other two bounds; `mimic` names the joint this
    one follows (position = mimic_multiplier x that joint's + mimic_offset); `actuated` says a
    <transmission> names the joint, `commanded` that a <ros2_control> block gives it a command interface.
    """

    joint: str
    joint_type: str
    parent: str
    child: str
    origin: Origin
    axis: Vector = (1.0, 0.0, 0.0)
    limits: tuple[float, float] | None = None
    mimic: str | None = None
    mimic_multiplier: float = 1.0
    actuated: bool = False
    velocity: float | None = None
    effort: float | None = None
    mimic_offset: float = 0.0
    commanded: bool = False

    @property
    def driven(self) -> bool:
        """A motor drives it: a <transmission> or a <ros2_control> command interface names it."""
        return self.actuated or self.commanded

    @property
    def movable(self) -> bool:
        """Moves (any type but fixed), or is declared actuated although written fixed."""
        return self.joint_type != "fixed" or self.actuated

    @property
    def moves(self) -> bool:
        """Movable, and not held still by limits that give it no range (lower = upper)."""
        return self.movable and not (self.limits is not None and self.limits[0] == self.limits[1])

    @property
    def independent(self) -> bool:
        """Moves of its own: movable and following no other joint through <mimic>."""
        return self.movable and self.mimic is None

    @property
    def bounded(self) -> bool:
        """A continuous joint its file gives a range of less than half a turn all the same (a linkage's bar, free
        in the tree but held by the loop it closes): it moves within that range."""
        return self.joint_type == "continuous" and self.limits is not None \
            and 0.0 < self.limits[1] - self.limits[0] < pi

    @property
    def spins(self) -> bool:
        """Turns without bound, following no other joint: continuous but not `bounded`, or revolute with no range
        given (the URDF spec would read such a joint as locked at 0; files write wheels so, meaning continuous)."""
        return self.mimic is None and ((self.joint_type == "continuous" and not self.bounded)
                                       or (self.joint_type == "revolute" and self.limits is None))


class TreeError(URDFError, ValueError):
    """Links and joints that do not form one rooted tree; `element` names the culprit."""

    status = 400


def _to_parent(origin: Origin, point: Vector) -> Vector:
    """Express a point given in a joint's child frame in its parent frame."""
    x, y, z = rotate_rpy(origin.rpy, point)
    return (x + origin.xyz[0], y + origin.xyz[1], z + origin.xyz[2])


def _tupled(value):
    """JSON arrays back to the tuples the dataclasses hold."""
    return tuple(value) if isinstance(value, list) else value


def _first_duplicate(names: Iterable[str]) -> str | None:
    seen: set[str] = set()
    for name in names:
        if name in seen:
            return name
        seen.add(name)
    return None


def check_tree(links: Iterable[str], joints: Iterable[tuple[str, str, str]]) -> str:
    """Check that (joint, parent, child) triples join `links` into one tree; return its root.

    Raises TreeError naming the offending link or joint.
    """
    links, joints = tuple(links), tuple(joints)
    if not links:
        raise TreeError("robot has no links", "robot")
    for kind, names in (("link", links), ("joint", (j for j, _, _ in joints))):
        if (dup := _first_duplicate(names)) is not None:
            raise TreeError(f"duplicate {kind} name '{dup}'", f"{kind} '{dup}'")
    parent_of = _parent_map(set(links), joints)
    roots = [link for link in links if link not in parent_of]
    if not roots:
        raise TreeError(f"cycle through links {_cycle(links[0], parent_of)}", f"link '{links[0]}'")
    if len(roots) > 1:
        raise TreeError(f"several root links: {', '.join(roots)}", f"link '{roots[1]}'")
    _check_reachable(roots[0], links, parent_of)
    return roots[0]


def _parent_map(known: set[str], joints: tuple[tuple[str, str, str], ...]) -> dict[str, str]:
    parent_of: dict[str, str] = {}
    for joint, parent, child in joints:
        for role, link in (("parent", parent), ("child", child)):
            if link not in known:
                raise TreeError(f"joint '{joint}' names unknown {role} link '{link}'", f"joint '{joint}'")
        if child in parent_of:
            raise TreeError(
                f"link '{child}' has two parents: '{parent_of[child]}' and '{parent}'", f"joint '{joint}'"
            )
        parent_of[child] = parent
    return parent_of


def _check_reachable(root: str, links: tuple[str, ...], parent_of: dict[str, str]) -> None:
    """Every link must reach the root; with one parent each, one that cannot lies on or below a cycle."""
    reached = {root}
    for link in links:
        path: dict[str, None] = {}
        while link not in reached:
            if link in path:
                raise TreeError(f"cycle through links {_cycle(link, parent_of)}", f"link '{link}'")
            path[link] = None
            link = parent_of[link]
        reached.update(path)


def _cycle(start: str, parent_of: dict[str, str]) -> str:
    """The cycle reached by following parents from `start`, as 'a -> b -> a'."""
    order: list[str] = []
    link = start
    while link not in order:
        order.append(link)
        link = parent_of[link]
    loop = order[order.index(link):] + [link]
    return " -> ".join(loop)


@dataclass(frozen=True)
class KinematicTree:
    """An immutable, validated kinematic tree; links and edges keep document order.

    Construction raises TreeError unless the edges join the links into one tree.
    Methods taking a link name raise KeyError for unknown names.
    """

    robot_name: str
    links: tuple[str, ...]
    edges: tuple[Edge, ...]
    evidence: Mapping[str, LinkEvidence] = field(default_factory=dict, hash=False)  # link → what the URDF says of it
    source_sha256: str = field(default="", compare=False)  # of the URDF document ingested (after xacro expansion)
    root: str = field(init=False)
    _parent_edge: dict[str, Edge] = field(init=False, repr=False, compare=False)
    _children: dict[str, tuple[str, ...]] = field(init=False, repr=False, compare=False)
    ranged: bool = field(init=False, repr=False, compare=False)  # some joint's limits give it a range (Edge.moves)

    def __post_init__(self) -> None:
        links, edges = tuple(self.links), tuple(self.edges)
        root = check_tree(links, ((e.joint, e.parent, e.child) for e in edges))
        children: dict[str, list[str]] = {link: [] for link in links}
        for edge in edges:
            children[edge.parent].append(edge.child)
        for name, value in (
            ("links", links),
            ("edges", edges),
            ("root", root),
            ("_parent_edge", {e.child: e for e in edges}),
            ("_children", {link: tuple(kids) for link, kids in children.items()}),
            ("ranged", any(e.moves for e in edges)),
        ):
            object.__setattr__(self, name, value)

    def to_dict(self) -> dict:
        """A JSON-ready form of the tree (from_dict rebuilds it): what a store keeps of a robot."""
        return {"robot_name": self.robot_name, "links": list(self.links), "edges": [asdict(e) for e in self.edges],
                "evidence": {link: asdict(facts) for link, facts in self.evidence.items()},
                "source_sha256": self.source_sha256}

    @classmethod
    def from_dict(cls, data: dict) -> KinematicTree:
        edges = tuple(Edge(**{k: _tupled(v) for k, v in e.items()} | {"origin": Origin(*map(tuple, e["origin"].values()))})
                      for e in data["edges"])
        evidence = {link: LinkEvidence.from_dict(facts) for link, facts in data.get("evidence", {}).items()}
        return cls(data["robot_name"], tuple(data["links"]), edges, evidence, data.get("source_sha256", ""))

    def moving(self, edge: Edge) -> bool:
        """The joint moves its child: Edge.moves, or movable with limits that give it no range in a file that gives
        no joint a range (SolidWorks' exporter writes every joint 0..0 unless told: there the limits say nothing)."""
        return edge.moves or (edge.movable and not self.ranged)

    def _known(self, link: str) -> str:
        if link not in self._children:
            raise KeyError(link)
        return link

    def parent(self, link: str) -> str | None:
        """The parent link, or None for the root."""
        edge = self.parent_edge(link)
        return edge.parent if edge else None

    def parent_edge(self, link: str) -> Edge | None:
        """The joint from the parent to this link, or None for the root."""
        return self._parent_edge.get(self._known(link))

    def edge_to(self, link: str) -> Edge:
        """The joint from the parent to this link; raises ValueError for the root, which has none."""
        edge = self.parent_edge(link)
        if edge is None:
            raise ValueError(f"the root link '{link}' has no parent joint")
        return edge

    def children(self, link: str) -> tuple[str, ...]:
        """Direct children in document order of their joints."""
        return self._children[self._known(link)]

    def leaves(self) -> tuple[str, ...]:
        """Links without children, in document order."""
        return tuple(link for link in self.links if not self._children[link])

    def is_leaf(self, link: str) -> bool:
        return not self.children(link)

    def chain_to_root(self, link: str) -> tuple[str, ...]:
        """(link, parent, ..., root)."""
        chain = [self._known(link)]
        while (edge := self._parent_edge.get(chain[-1])) is not None:
            chain.append(edge.parent)
        return tuple(chain)

    def descendants(self, link: str) -> tuple[str, ...]:
        """All links below `link`, depth-first in document order, excluding `link`."""
        found: list[str] = []
        stack = list(reversed(self.children(link)))
        while stack:
            current = stack.pop()
            found.append(current)
            stack.extend(reversed(self._children[current]))
        return tuple(found)

    def position_in(self, link: str, ancestor: str, point: Vector = (0.0, 0.0, 0.0)) -> Vector:
        """A point given in `link`'s frame (default its origin), expressed in `ancestor`'s frame (joints at zero).

        Raises ValueError if `ancestor` is not on `link`'s chain to the root.
        """
        return self._express(link, ancestor, point, _to_parent)

    def direction_in(self, link: str, ancestor: str, vector: Vector) -> Vector:
        """A direction given in `link`'s frame (a joint's axis, in its child's frame), expressed in `ancestor`'s
        frame (joints at zero): turned, not moved."""
        return self._express(link, ancestor, vector, lambda origin, v: rotate_rpy(origin.rpy, v))

    def _express(self, link: str, ancestor: str, value: Vector, step) -> Vector:
        self._known(ancestor)
        current = self._known(link)
        while current != ancestor:
            edge = self._parent_edge.get(current)
            if edge is None:
                raise ValueError(f"'{ancestor}' is not an ancestor of '{link}'")
            value = step(edge.origin, value)
            current = edge.parent
        return value

    def without(self, links: Iterable[str]) -> KinematicTree:
        """This tree minus `links` and the joints leading to them.

        Raises ValueError unless `links` excludes the root and holds every descendant of each member.
        """
        removed = {self._known(link) for link in links}
        if self.root in removed:
            raise ValueError(f"cannot remove the root link '{self.root}'")
        for link in removed:
            kept = next((c for c in self._children[link] if c not in removed), None)
            if kept is not None:
                raise ValueError(f"'{link}' is removed but its child '{kept}' is not")
        return KinematicTree(
            self.robot_name,
            tuple(link for link in self.links if link not in removed),
            tuple(edge for edge in self.edges if edge.child not in removed),
            {link: facts for link, facts in self.evidence.items() if link not in removed},
            self.source_sha256,
        )


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
