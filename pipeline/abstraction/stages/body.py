"""The body pass: every movable joint not owned by a device, grouped into body parts and classified.

Structure proposes; the ontology and the model decide. Candidates are the serial chains of body
joints (not those placing the whole robot: frames.placing_joints) between branch points (a link from
which two or more chains go on), cut after a sliding joint that lifts turning ones, with a trailing joint that spins
(continuous, or revolute with no range) and carries nothing but a wheel's body (hands.wheel_body) split off as a wheel
candidate. A joint hung from a drawn body that moves bare frames alone (no body drawn, no device) and that no
motor drives (_moves_nothing) is no candidate. A joint that follows another by <mimic>, moves nothing that moves
on its own and belongs to that joint's limb (a second motor on its pivot, a linkage's bar below it: _followers) is
no candidate: what it moves joins the part of the joint it follows. The code asserts what structure says of
each (its joint types, the devices on its links, the candidates hanging from it, whether it reaches
the ground) and the reasoner applies the ontology's sufficient conditions for the BodyPart classes
(a part carrying an end-effector off the ground is an arm, ...). The model classifies the
candidates those leave open among the BodyPart classes (or none: a device's mechanism), shown: its
joints with their type and the direction of their axis in the robot's frame, the links it moves,
what it hangs from, what it carries (devices, further chains) and whether it reaches the ground; those
that carry others then go through the reasoner again, the others' classes asserted (an arm on either side
makes a torso). Where no part moves the robot about, a main body resting on wheels the file fixed, carrying
devices in a file with no movable joint, carrying rotors, or moved in the ground plane by the joints placing the robot
is a mobile base with no joints (jointless_base).
Adjacent chains given the same class join (a shoulder joint split off by a head hung on the same
link); chains of the mobile base join it, around the chassis its wheels and base joints hang from.
`side` comes from geometry (REP 103: +y of the root frame is left, at the zero pose), checked once
per class of mirrored parts against the model's reading of the names, which wins where it is sure.
"""
from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace

from urdfkb.pipeline.knowledge import reasoning
from urdfkb.pipeline.abstraction.components import END_EFFECTOR, BodyPart, Component
from urdfkb.pipeline.reading.evidence import named
from urdfkb.pipeline.knowledge.ontology import Vocabulary
from urdfkb.pipeline.abstraction.oracle import Oracle
from urdfkb.pipeline.abstraction.prompts import NONE, Choice, body_choice, side_question
from urdfkb.pipeline.abstraction.frames import is_frame, mirrored, placeholder, placing_joints
from urdfkb.pipeline.abstraction import structure
from urdfkb.pipeline.abstraction.hands import PARALLEL, feet, palm, wheel_body
from urdfkb.pipeline.abstraction.stages.asking import Progress, ask
from urdfkb.pipeline.reading.tree import Edge, KinematicTree, Vector, fork_of
from urdfkb.pipeline.abstraction.vectors import dot, norm, unit

SIDE_EPS = 0.01   # m: a part nearer the root's x-z plane has no side
GROUND_EPS = 0.02  # m: a chain whose links come this near the robot's lowest frame reaches the ground
NAMES_WIN = 0.75  # the model's reading of the names overrules geometry for a class at this share
UPRIGHT = math.cos(math.radians(6))  # an axis within 6 degrees of the vertical: a turn in the ground plane
PROPELLERS = 2  # idle joints spinning on a main body that make it a vehicle (one alone may be a spinning lidar)
LEG = "Leg"
HEAD = "Head"
ARM = "Arm"
CAMERA = "Camera"
ARM_ALONE = 5  # joints off the ground carrying no further part: an arm by its joints alone (the ontology's condition)
ROOT = "nothing: it is the robot's root"
Log = Callable[[str], None]


@dataclass
class Chain:
    """A candidate: serial body joints (root-most first) and the links they move."""

    joints: list[Edge]
    links: list[str]
    cls: str = NONE
    confidence: float = 0.0

    @property
    def mount(self) -> str:
        return self.joints[0].parent

    @property
    def end(self) -> str:
        return self.joints[-1].child


def device_joints(tree: KinematicTree, comp: Component) -> tuple[str, ...]:
    """The movable joints on the paths from a component's mount to its links (an end-effector's fingers)."""
    found: dict[str, None] = {}
    for link in comp.links:
        for current in tree.chain_to_root(link):
            if current == comp.root:
                break
            edge = tree.edge_to(current)
            if edge.movable:
                found[edge.joint] = None
    return tuple(j for j in (e.joint for e in tree.edges) if j in found)


def chains(tree: KinematicTree, owned_joints: set[str], owned_links: set[str]) -> list[Chain]:
    """Candidate chains of body joints, in document order of their first joints; no sensor mount (_mounts)."""
    placing, mounts = placing_joints(tree), _mounts(tree, owned_links)
    movable = [e for e in tree.edges if e.movable and e.joint not in owned_joints | placing | mounts
               and not _moves_nothing(tree, e, owned_links)]
    followers = _followers(tree, movable)
    body = [e for e in movable if e.joint not in followers]
    names = {e.joint for e in movable}
    upper = {e.joint: _upper(tree, e, names) for e in body}
    below: dict[str | None, list[Edge]] = {}
    for e in body:
        below.setdefault(upper[e.joint], []).append(e)
    out = []
    for start in body:
        above = upper[start.joint]
        if above is not None and len(below[above]) == 1:
            continue  # continues its upper joint's chain
        run = [start]
        while len(below.get(run[-1].joint, ())) == 1:
            run.append(below[run[-1].joint][0])
        out += [piece for part in _split_lifts(run) for piece in _split_wheel(tree, part, below, owned_links)]
    for chain in out:
        chain.links = [link for e in chain.joints for link in _moved(tree, e.child, names, owned_links)]
    by_joint = {e.joint: chain for chain in out for e in chain.joints}
    for edge in movable:
        if followers.get(edge.joint) in by_joint:
            by_joint[followers[edge.joint]].links += _moved(tree, edge.child, names, owned_links)
    return out


def _followers(tree: KinematicTree, movable: list[Edge]) -> dict[str, str]:
    """Joints that follow another of `movable` through <mimic>, move nothing that moves on its own and belong to
    that joint's limb: a second motor on the same axis (hung from the same link, its pivot on the other's, the axes
    parallel) or a linkage's bar hung below it. Each maps to the first joint of `movable` up its <mimic> chain that
    is no such follower: no candidate of its own, what it moves joins that joint's part. A follower elsewhere (a
    skid-steer base's rear wheel following the front one, a finger following a thumb) stays a candidate."""
    names = {e.joint for e in movable}
    dead_ends = {e.joint: e for e in movable if e.mimic is not None
                 and not any(tree.edge_to(x).independent for x in tree.descendants(e.child))}
    found: dict[str, str] = {}
    for edge in dead_ends.values():
        followed = next((e for e, _ in structure.followed(tree, edge)[1:]
                         if e.joint in names and e.joint not in dead_ends), None)
        if followed is not None and (_same_pivot(tree, edge, followed)
                                     or followed.child in tree.chain_to_root(edge.parent)):
            found[edge.joint] = followed.joint
    return found


def _same_pivot(tree: KinematicTree, a: Edge, b: Edge) -> bool:
    """Two joints hung from one link, their pivots within SIDE_EPS of each other and their axes parallel."""
    if a.parent != b.parent:
        return False
    axis_a, axis_b = (unit(tree.direction_in(e.child, e.parent, e.axis)) for e in (a, b))
    return axis_a is not None and axis_b is not None and abs(dot(axis_a, axis_b)) >= PARALLEL \
        and math.dist(a.origin.xyz, b.origin.xyz) <= SIDE_EPS


def _mounts(tree: KinematicTree, owned_links: set[str]) -> frozenset[str]:
    """Joints whose limits leave them no range (lower = upper) and that carry devices' links, nothing below them
    moving: sensor mounts written revolute so that a simulator keeps their links apart (UUV Simulator, RotorS, VRX),
    with the device's housing where the file gives other joints a range. A joint so written that carries a link of
    the body is the robot's (SolidWorks' exporter writes every joint 0..0 unless told: where no joint has a range,
    only one carrying devices' links alone is a mount), and one that spins (Edge.spins: a wheel's, whatever limits
    its file writes) is never a mount. The housing is one body: a joint whose links beside the devices' have a joint
    of their own below it is a limb's, and so is one hanging from such a joint (a hand-written arm whose every joint
    is 0..0, ending in a gripper, in a file whose lift has a range)."""
    ranged = tree.ranged

    def held(edge: Edge | None) -> bool:
        return edge is not None and edge.movable and not edge.moves and not edge.spins

    def mount(edge: Edge) -> bool:
        carried = {edge.child, *tree.descendants(edge.child)}
        if carried <= owned_links:
            return True
        still = not any(tree.edge_to(link).moves for link in carried if link != edge.child)
        rigid = not any(tree.edge_to(link).movable for link in carried - owned_links if link != edge.child)
        return ranged and still and rigid and bool(carried & owned_links)
    mounts = {e.joint: e for e in tree.edges if held(e) and mount(e)}

    def limb(edge: Edge) -> bool:  # hangs from a held joint that is no mount
        above = tree.parent_edge(edge.parent)
        return above is not None and held(above) and above.joint not in mounts
    return frozenset(j for j, e in mounts.items() if not limb(e))


def _moves_nothing(tree: KinematicTree, edge: Edge, owned_links: set[str]) -> bool:
    """The joint hangs from a drawn body and moves bare frames alone (frames.is_frame: nothing drawn, none of them a
    device's), and no motor drives it (Edge.driven): a point a simulator plugin reads, no part of the body. A driven
    one moves what the file draws elsewhere; a file drawing nothing at all still has its joints."""
    moved = {edge.child, *tree.descendants(edge.child)}
    return not edge.driven and not is_frame(tree, edge.parent) and not moved & owned_links \
        and all(is_frame(tree, link) for link in moved)


def _upper(tree: KinematicTree, edge: Edge, body: set[str]) -> str | None:
    for link in tree.chain_to_root(edge.parent):
        above = tree.parent_edge(link)
        if above is not None and above.joint in body:
            return above.joint
    return None


def _split_lifts(run: list[Edge]) -> list[list[Edge]]:
    """A run is cut after each sliding joint followed by a turning one: a lift and what it lifts are two
    candidates (they join again where the model gives them one class)."""
    pieces = [[run[0]]]
    for previous, edge in zip(run, run[1:]):
        if previous.joint_type == "prismatic" and edge.joint_type in ("revolute", "continuous"):
            pieces.append([])
        pieces[-1].append(edge)
    return pieces


def _motion(tree: KinematicTree, edge: Edge) -> str:
    """The joint type the reasoner is told: what the joint does, so a joint that spins (Edge.spins) is continuous
    whatever the file wrote where it spins a wheel's body (wheel_body) or carries joints on, and revolute where it
    swings a body out from its axis with nothing moving below (a neck or a limb whose file leaves its limits out:
    no wheel rolls so); a continuous one its file bounds (Edge.bounded), or that follows by <mimic> a joint whose
    range it turns through less than half a turn of (_follows_bounded: a linkage's bar following an arm's joint), is
    revolute."""
    if edge.spins:
        carries_on = any(tree.edge_to(x).movable for x in tree.descendants(edge.child))
        return "continuous" if carries_on or wheel_body(tree, edge.child) else "revolute"
    return "revolute" if edge.bounded or _follows_bounded(tree, edge) else edge.joint_type


def _follows_bounded(tree: KinematicTree, edge: Edge) -> bool:
    """A turning joint follows by <mimic> a turning joint with a range, over less than half a turn of its own: it
    moves within that arc as its source does, as no wheel does."""
    source, rate = structure.followed(tree, edge)[-1]
    turning = ("revolute", "continuous")
    return source is not edge and edge.joint_type in turning and source.joint_type in turning \
        and source.limits is not None and 0.0 < (source.limits[1] - source.limits[0]) * abs(rate) < math.pi


def _split_wheel(tree: KinematicTree, run: list[Edge], below: dict, owned_links: set[str]) -> list[Chain]:
    """A trailing joint that spins and carries nothing (no further joint, no device) but a wheel's body
    (wheel_body: a leg's last segment written continuous carries its foot out from the knee) is its own
    candidate."""
    last = run[-1]
    carries = {last.child, *tree.descendants(last.child)} & owned_links
    if len(run) > 1 and wheel_body(tree, last.child) and not below.get(last.joint) and not carries:
        return [Chain(run[:-1], []), Chain([last], [])]
    return [Chain(run, [])]


def _moved(tree: KinematicTree, link: str, body: set[str], owned_links: set[str]) -> list[str]:
    """`link` and what hangs from it by joints that are not body joints, minus devices' links."""
    out, stack = [], [link]
    while stack:
        current = stack.pop()
        if current not in owned_links:
            out.append(current)
        stack += [c for c in reversed(tree.children(current)) if tree.edge_to(c).joint not in body]
    return out


# --- evidence --------------------------------------------------------------------------------

def _direction(tree: KinematicTree, edge: Edge) -> str:
    """The joint axis in the root frame at the zero pose, in words (REP 103: x forward, y left, z up)."""
    axis = tree.direction_in(edge.child, tree.root, edge.axis)
    dominant = max(range(3), key=lambda i: abs(axis[i]))
    if edge.joint_type == "prismatic":
        return ("slides forward-back", "slides sideways", "slides up-down")[dominant]
    return ("rolls about the forward axis", "pitches about the sideways axis", "turns about the vertical axis")[dominant]


def _height(tree: KinematicTree, link: str) -> float:
    return tree.position_in(link, tree.root)[2]


def evidence(tree: KinematicTree, chain: Chain, carried: list[str], further: int, grounded: bool) -> str:
    """What structure says of a candidate, in a few lines."""
    joints = ", ".join(f"{e.joint} ({e.joint_type}, {_direction(tree, e)})" for e in chain.joints)
    lines = [f"Joints: {joints}", f"Links: {', '.join(chain.links[:-1] + [named(tree.evidence, chain.links[-1])])}",
             f"Hangs from: {chain.mount}"]
    ends = list(carried) + ([f"{further} more moving chain{'s' if further > 1 else ''}"] if further else [])
    lines.append("Carries: " + ("; ".join(ends) if ends else "nothing"))
    if grounded:
        lines.append("Reaches the ground: its end is the robot's lowest point")
    return "\n".join(lines)


# --- what the body pass's steps call (pipeline.abstraction.steps.body; pipeline.abstraction.abstractor.BODY_PASS runs them in order) ----

def with_joints(tree: KinematicTree, components: list[Component]) -> list[Component]:
    """The components, each end-effector with the movable joints of its fingers (`device_joints`)."""
    return [replace(c, joints=device_joints(tree, c)) if c.kind == END_EFFECTOR else c for c in components]


def candidates(tree: KinematicTree, components: list[Component]) -> list[Chain]:
    """The candidate chains among the joints and links no device owns."""
    owned_joints = {j for c in components for j in device_joints(tree, c)}
    return chains(tree, owned_joints, {link for c in components for link in c.links})


Reasoned = tuple[list[reasoning.PartFacts], list[str | None]]  # candidates' facts, and the class of each


@dataclass
class Findings:
    """What structure says of each candidate: the devices it carries, the candidates hanging from it,
    whether it reaches the ground, and the facts the code asserts of it for the reasoner."""

    devices: list[list[Component]]
    carries: list[list[int]]
    grounded: list[bool]
    facts: list[reasoning.PartFacts]


def findings(tree: KinematicTree, found: list[Chain], components: list[Component]) -> Findings:
    """Each candidate's devices (the components whose mount it holds), followers and ground contact."""
    by_link = {link: ch for ch in found for link in ch.links}
    lowest = min(_height(tree, link) for link in tree.links if link != tree.root)
    standing = feet(tree)
    devices = [[c for c in components if _nearest(tree, c.root, by_link) is chain] for chain in found]
    carries = [[i for i, other in enumerate(found) if other is not chain and other.mount in chain.links] for chain in found]
    tools = {link for c in components if c.kind == END_EFFECTOR for link in c.links}
    grounded = [_reaches_ground(tree, chain, lowest, tools, standing) for chain in found]
    facts = [reasoning.PartFacts(tuple(_motion(tree, e) for e in chain.joints), tuple(c.cls for c in held),
                                 tuple(follow), ground, _side_of(tree, chain), span=_span(tree, chain, held),
                                 vertical=all(_turns_about_vertical(tree, e) for e in chain.joints),
                                 sliding=all(e.joint_type == "prismatic" for e in chain.joints))
             for chain, held, follow, ground in zip(found, devices, carries, grounded)]
    return Findings(devices, carries, grounded, facts)


VERTICAL = math.cos(math.radians(30))  # a joint's axis this close to the root's z turns about the vertical


def _turns_about_vertical(tree: KinematicTree, edge: Edge) -> bool:
    """The joint turns (revolute or continuous) about an axis within 30 degrees of the vertical (the root's z,
    REP 103) at the zero pose, and what it turns is no ball (drawn as a sphere, which rolls about any axis whatever
    the one written: a ball caster's three joints)."""
    facts = tree.evidence.get(edge.child)
    if edge.joint_type not in ("revolute", "continuous") or (facts is not None and facts.shape.startswith("sphere")):
        return False
    axis = unit(tree.direction_in(edge.child, tree.root, edge.axis))
    return axis is not None and abs(axis[2]) >= VERTICAL


def _span(tree: KinematicTree, chain: Chain, held: list[Component]) -> float:
    """How far the farthest link of the devices `held` on a candidate lies from its first joint, at the zero pose."""
    first = chain.joints[0].child
    return max((norm(tree.position_in(link, first)) for c in held for link in c.links), default=0.0)


def classify(oracle: Oracle, tax: Vocabulary, tree: KinematicTree, found: list[Chain],
             components: list[Component], progress: Progress | None, log: Log,
             reasoned: Callable[[float], None] = lambda _seconds: None, known: Reasoned | None = None,
             reasoner: reasoning.Reasoner | None = None) -> None:
    """Each candidate's class: structure first (the ontology's sufficient conditions, by `reasoner`: HermiT
    by default), the model for the rest; `reasoned` receives the reasoner's wall time. `known` is what an
    earlier reasoner run inferred for candidates' facts, taken where the facts are still these."""
    if not found:
        return
    seen = findings(tree, found, components)
    devices, carries, grounded = seen.devices, seen.carries, seen.grounded
    if known is not None and known[0] == seen.facts:
        inferred, seconds = list(known[1]), 0.0
        log("body reasoner: inferred in the end-effector pass's run")
    else:
        inferred, seconds = reasoning.classify_parts(seen.facts, reasoner)
    reasoned(seconds)
    log(f"body reasoner: {seconds:.2f} s, " + ", ".join(f"{c.joints[0].joint}={cls}" for c, cls in zip(found, inferred)))
    open_ = [i for i, cls in enumerate(inferred) if cls is None]
    for i, cls in enumerate(inferred):
        if cls is not None:
            found[i].cls, found[i].confidence = cls, _resting_on(tax, cls, devices[i], seen.facts[i])
    questions = [_offering(body_choice(tax, evidence(tree, found[i], [tax.label(c.cls) for c in devices[i]],
                                                     len(carries[i]), grounded[i]), f"body:{found[i].joints[0].joint}"),
                           _stated_otherwise(tax, seen.facts[i])) for i in open_]
    verdicts = ask(oracle, [q.question for q in questions], "body classification", progress)
    for i, question, verdict in zip(open_, questions, verdicts):
        found[i].cls = question.meant(verdict.answer, NONE)
        found[i].confidence = verdict.confidence
    shares = {i: {question.meaning[a]: share for a, share in verdict.distribution.items() if a in question.meaning}
              for i, question, verdict in zip(open_, questions, verdicts)}
    reasoned(_carriers_again(found, seen.facts, shares, log, reasoner))


def _resting_on(tax: Vocabulary, cls: str, held: list[Component], facts: reasoning.PartFacts) -> float:
    """The confidence of a class the ontology settled: that of the devices its condition rests on, the most
    confident of them (a head's cameras; an arm's end-effectors, where fewer than five joints or a further part leave
    it resting on them: a neck carrying a tool the model only half believed in is an arm no more surely), else 1.0 (what
    the joints and the ground settle)."""
    if cls == HEAD:
        rest = [c for c in held if tax.is_a(c.cls, CAMERA)]
    elif cls == ARM and (len(facts.joint_types) < ARM_ALONE or facts.carries):
        rest = [c for c in held if c.kind == END_EFFECTOR]
    else:
        return 1.0
    return max((c.confidence for c in rest), default=1.0)


def _stated_otherwise(tax: Vocabulary, facts: reasoning.PartFacts) -> frozenset[str]:
    """The body-part classes the values the ontology states on them rule out for a candidate: a wheel turns about a
    level axis (core:turnsAboutVertical), a head does not only slide (core:slidesOnly)."""
    return tax.turning_otherwise(facts.vertical, tax.body_classes) | tax.sliding_otherwise(facts.sliding,
                                                                                          tax.body_classes)


def _offering(choice: Choice, ruled_out: frozenset[str]) -> Choice:
    """The question without the classes the candidate's facts rule out by the ontology (a wheel turns about a level
    axis, a head does not only slide): its text unchanged, so the prompt's cached prefix still serves it."""
    kept = {answer: meant for answer, meant in choice.meaning.items() if meant not in ruled_out}
    return Choice(replace(choice.question, options=tuple(kept)), kept)


def _carriers_again(found: list[Chain], facts: list[reasoning.PartFacts], shares: dict[int, dict[str, float]],
                    log: Log, reasoner: reasoning.Reasoner | None) -> float:
    """The candidates the model classified that carry others, once more through the reasoner with the classes of
    all the others asserted (the ontology's conditions on what a part carries: an arm on either side makes a
    torso); where it settles a class the model did not give, that class, with the model's share for it as the
    confidence. The reasoner's wall time (0 where no such candidate carries a settled one)."""
    again = [i for i in shares if facts[i].carries and any(found[k].cls != NONE for k in facts[i].carries)]
    if not again:
        return 0.0
    known = [replace(f, known=None if i in again or found[i].cls == NONE else found[i].cls)
             for i, f in enumerate(facts)]
    inferred, seconds = reasoning.classify_parts(known, reasoner)
    for i in again:
        if (cls := inferred[i]) is not None and cls != found[i].cls:
            log(f"body:{found[i].joints[0].joint}: {cls} by what it carries, not {found[i].cls}")
            found[i].cls, found[i].confidence = cls, shares[i].get(cls, 0.0)
    return seconds


def _side_of(tree: KinematicTree, chain: Chain) -> str | None:
    """The side of the root's x-z plane a candidate's joints lie on (their child links at the zero pose)."""
    y = _mean_position(tree, [e.child for e in chain.joints])[1]
    return "left" if y > SIDE_EPS else "right" if y < -SIDE_EPS else None


def _reaches_ground(tree: KinematicTree, chain: Chain, lowest: float, tools: set[str],
                    standing: frozenset[str]) -> bool:
    """What the chain moves comes down to the robot's lowest frame, below where it hangs from (an arm on a
    fixed base holds the lowest frames too, but above its mount). An end-effector's links (`tools`) do not count:
    a gripper an arm points down below its own base at the zero pose does not make the arm a leg. A chain of two
    joints or more reaches it where it moves a foot the robot stands on (`standing`, hands.feet: a leg, even one the
    zero pose holds out level), or comes down there at a wheel (a joint that spins): the arms of an upper body on a
    stand the file leaves out hang lowest, but nothing stands on them."""
    moved = [link for e in chain.joints for link in (e.child, *tree.descendants(e.child)) if link not in tools]
    if not moved:
        return False
    if len(chain.joints) >= 2 and standing & set(moved):
        return True
    if len(chain.joints) >= 2 and not any(tree.edge_to(link).spins for link in moved):
        return False
    reach = min(_height(tree, link) for link in moved)
    return reach <= lowest + GROUND_EPS and reach < _height(tree, chain.mount) - GROUND_EPS


def _nearest(tree: KinematicTree, link: str, by_link: dict[str, Chain]) -> Chain | None:
    """The chain whose links hold `link` or its nearest ancestor."""
    return next((by_link[a] for a in tree.chain_to_root(link) if a in by_link), None)


def _join(tax: Vocabulary, tree: KinematicTree, found: list[Chain]) -> list[Chain]:
    """A chain of a joining class (every body class but the base, whose chains join around its chassis,
    and the wheel) is one part with the followers of that class hanging from its links (a neck with the pan-tilt
    unit and the turning sensor ring it carries), unless two of them lie on either side of the robot (two
    limbs: two arms below a chain the model also called an arm); a head's do all the same (its eyes, each turning
    its camera)."""
    joining = set(tax.body_classes) - {tax.mobile_base, tax.wheel}
    joined = True
    while joined:
        joined = False
        for parent in found:
            followers = [c for c in found if c is not parent and c.mount in parent.links and c.cls == parent.cls]
            if parent.cls in joining and followers and (parent.cls == HEAD or not _either_side(tree, followers)):
                for child in followers:
                    parent.joints += child.joints
                    parent.links += child.links
                    parent.confidence = min(parent.confidence, child.confidence)
                    found.remove(child)
                joined = True
                break
    return found


def _either_side(tree: KinematicTree, chains: list[Chain]) -> bool:
    """Two of `chains` lie on either side of the root's x-z plane (their joints' child links, at the zero pose)."""
    return _either_side_of([_mean_position(tree, [e.child for e in c.joints])[1] for c in chains])


def assemble(tax: Vocabulary, tree: KinematicTree, found: list[Chain]) -> list[BodyPart]:
    """Body parts from the classified candidates: adjacent chains of one joining class as one part, the
    base chains joined into one MobileBase around its chassis; candidates classified none drop out."""
    return _parts(tax, tree, [c for c in _join(tax, tree, found) if c.cls != NONE])


def _parts(tax: Vocabulary, tree: KinematicTree, found: list[Chain]) -> list[BodyPart]:
    """Body parts: one per chain, the base chains joined into one MobileBase around its chassis."""
    base, wheel = tax.mobile_base, tax.wheel
    base_chains = [c for c in found if c.cls == base]
    wheels = [c for c in found if c.cls == wheel]
    parts = [BodyPart(f"{c.cls.lower()}_{c.joints[0].joint}", c.cls, round(c.confidence, 4), c.mount,
                      tuple(e.joint for e in c.joints), tuple(c.links))
             for c in found if c.cls != base]
    if not base_chains and not wheels:
        return parts
    chassis = fork_of(tree, [c.mount for c in base_chains + wheels])
    joints = tuple(e.joint for c in base_chains for e in c.joints)
    links = tuple(dict.fromkeys([chassis, *(link for c in base_chains for link in c.links)]))
    root = base_chains[0].mount if base_chains else tree.parent(chassis)
    confidence = min([c.confidence for c in base_chains] or [1.0])
    mobile_base = BodyPart(f"mobile_base_{chassis}", base, round(confidence, 4), root, joints, links)
    return [mobile_base] + [replace(p, parent=mobile_base.name) if p.cls == wheel else p for p in parts]


def main_body(tree: KinematicTree, components: list[Component], idle: frozenset[str] = frozenset(),
              propelled: bool = False) -> str | None:
    """The link the robot's body starts at where no joint moves anything hanging from it: the first drawn link
    below the root through fixed joints and frames (frames.is_frame, and the dummy links between the joints placing
    it in the plane: frames.placeholder; below a frame carrying several links, the heaviest drawn one: a hull beside
    its decorative panels), owned by no device, no movable joint's parent (a
    drone's airframe, a base whose wheels the file fixes), but of `idle` joints, which move no body part (a drone's
    rotors), of joints held still (KinematicTree.moving: RotorS hangs its sensors' frames on revolute joints
    limited 0..0) and of the joints placing the robot where they move it in the ground plane (placed_in_plane), or,
    where PROPELLERS rotors or more spin on the root's rigid body (`propelled`) or the file moves the robot in the
    plane, whatever else it carries (a drone's camera gimbal or arm, a mobile manipulator's arm). None elsewhere: an
    arm's base carries its first joint."""
    planar = placed_in_plane(tree)
    idle, vehicle = idle | planar, propelled or bool(planar)

    def moves(child: str) -> bool:
        edge = tree.edge_to(child)
        return tree.moving(edge) and edge.joint not in idle
    placed = {e.child for e in tree.edges if e.joint in planar}
    link = tree.root
    while is_frame(tree, link) or (link in placed and placeholder(tree, link)):
        below = tree.children(link)
        held = [child for child in below if not (tree.edge_to(child).joint in idle and tree.is_leaf(child))]
        weighed = [(facts.mass, child) for child in held if not is_frame(tree, child)
                   and (facts := tree.evidence.get(child)) is not None and facts.mass is not None]
        if not held or any(moves(child) for child in below) or (len(held) > 1 and not weighed):
            return None
        link = held[0] if len(held) == 1 else max(weighed)[1]
    if link in {owned for c in components for owned in c.links} or (
            not vehicle and any(moves(child) for child in tree.children(link))):
        return None
    return link


def placed_in_plane(tree: KinematicTree) -> frozenset[str]:
    """The joints placing the whole robot (frames.placing_joints) where they move it in the ground plane alone (a planar
    joint, or sliding joints whose axes all lie level, with turns about the vertical): a ground vehicle whose file
    moves it by virtual x, y and yaw joints rather than by its wheels. Empty where they free it (a floating joint) or
    lift it."""
    placing = placing_joints(tree)
    up = (0.0, 0.0, 1.0)
    for e in tree.edges:
        if e.joint not in placing:
            continue
        axis = unit(tree.direction_in(e.child, tree.root, e.axis))
        upright = axis is not None and abs(dot(axis, up)) >= UPRIGHT  # a planar joint's axis is its plane's normal
        level = axis is not None and abs(dot(axis, up)) <= math.sqrt(1 - UPRIGHT ** 2)  # within 6 degrees of level
        if not (level if e.joint_type == "prismatic" else upright and e.joint_type != "floating"):
            return frozenset()
    return placing


def resting_wheels(tree: KinematicTree, body: str, owned: set[str]) -> list[str]:
    """The wheels a file fixed to `body`: drawn cylinders fixed below it, owned by no device, whose rims reach the
    robot's lowest frame, at least two of one radius on either side of the root's x-z plane (an omnidirectional
    base whose wheels the file writes as fixed links; a snake's segments lying on the ground lie on one line)."""
    lowest = min(_height(tree, link) for link in tree.links)
    by_radius: dict[float, list[str]] = {}
    for link in palm(tree, body):
        facts = tree.evidence.get(link)
        cylinder = facts.cylinder if facts is not None else None
        if link != body and link not in owned and cylinder is not None \
                and _height(tree, link) - cylinder[0] <= lowest + GROUND_EPS:
            by_radius.setdefault(round(cylinder[0], 3), []).append(link)
    return next((links for links in by_radius.values()
                 if len(links) > 1 and _either_side_of([tree.position_in(w, tree.root)[1] for w in links])), [])


def _either_side_of(y: list[float]) -> bool:
    """Lateral positions (y in the root frame) on either side of the root's x-z plane."""
    return max(y) > SIDE_EPS and min(y) < -SIDE_EPS


def jointless_base(oracle: Oracle, tax: Vocabulary, tree: KinematicTree, parts: list[BodyPart],
                   components: list[Component], progress: Progress | None, log: Log,
                   idle: frozenset[str] = frozenset()) -> list[BodyPart]:
    """Where no part moves the robot about (no mobile base, wheel or leg), a main body (`main_body`) that rests on
    wheels the file fixed (`resting_wheels`), that carries devices in a file where no joint moves a body part
    (none movable, or only `idle` ones, the joints of candidates that are no body part: a drone's airframe with its
    rotors, a boat's hull, a car whose wheels the file leaves out), or on which PROPELLERS or more `idle` joints spin
    (Edge.spins: a drone's rotors, a boat's propellers, whatever else moves on it, a camera gimbal), or that the file
    moves in the ground plane by the joints placing it (placed_in_plane: a holonomic base written without its
    wheels), is a mobile base with no joint of its own, which the ontology's MobileBase allows; fixed wheels stay its
    links. The body-part question, shown the body, what it carries and how it stands, offered mobile base or none,
    gives the part its confidence: the model's share for mobile base."""
    planar = placed_in_plane(tree)
    rigid = set(palm(tree, tree.root))  # the body and what is fixed to it: main_body reaches it by fixed joints
    rotors = [e.child for e in tree.edges if e.joint in idle and e.spins and e.parent in rigid]
    propelled = len(rotors) >= PROPELLERS
    body = main_body(tree, components, idle, propelled)
    if body is None or any(p.cls in (tax.mobile_base, tax.wheel, LEG) for p in parts):
        return parts
    if planar:
        rigid |= set(palm(tree, body))  # below the placing joints
    devices = [tax.label(c.cls) for c in components if c.root in rigid]
    wheels = resting_wheels(tree, body, {link for c in components for link in c.links})
    still = devices and not any(e.movable and e.joint not in idle for e in tree.edges)
    if not wheels and not still and not propelled and not planar:
        return parts
    hanging = [p for p in parts if p.root in rigid]
    carried = devices + ([f"{len(hanging)} moving chain{'s' if len(hanging) > 1 else ''}"] if hanging else [])
    moving = any(e.movable for e in tree.edges)
    moved = f"the file moves the whole robot in the plane by {', '.join(sorted(planar))}" if planar else (
        "no joint moves it" if wheels or moving else "the robot has no movable joint")
    shown = [f"Joints: none ({moved})",
             f"Links: {named(tree.evidence, body)}", f"Hangs from: {tree.parent(body) or ROOT}",
             "Carries: " + ("; ".join(carried) if carried else "nothing")]
    shown += [f"Reaches the ground: at {', '.join(wheels)}, fixed cylinders resting on it"] if wheels else []
    asked = body_choice(tax, "\n".join(shown), f"body:{body}")
    offered = {a: c for a, c in asked.meaning.items() if c in (tax.mobile_base, NONE)}
    (verdict,) = ask(oracle, [replace(asked.question, options=tuple(offered))], "body classification", progress)
    share = next((verdict.distribution.get(a, 0.0) for a, c in offered.items() if c == tax.mobile_base), 0.0)
    if wheels:
        why, evidence = "resting on wheels the file fixed", wheels
    elif still:
        why, evidence = "of a robot with no joint", devices
    elif propelled:
        why, evidence = "that its spinning rotors carry", rotors
    else:
        why, evidence = "the file moves in the plane", sorted(planar)
    log(f"body:{body}: a main body {why} ({', '.join(evidence)}): a mobile base,"
        f" the model's share {share:.2f}")
    return [BodyPart(f"mobile_base_{body}", tax.mobile_base, round(share, 4), tree.parent(body), (), (body, *wheels)),
            *parts]


def sides(oracle: Oracle, tree: KinematicTree, parts: list[BodyPart], progress: Progress | None,
          log: Log) -> list[BodyPart]:
    """left/right by the sign of y in the root frame for classes with parts on both sides; per such class,
    the model names the left one of its widest pair, and where it disagrees with geometry and is sure,
    the names win for the whole class.

    A robot with no such pair in any class may be drawn with another axis across it (a CAD export with y
    up): where a class's parts pair across the root's y-z or x-y plane instead, and every such class pairs
    across the same one, geometry gives no left, so the names alone decide, when the model is sure."""
    at = {p.name: _mean_position(tree, _anchor(tree, p)) for p in parts}
    axis = _lateral_axis(parts, at)
    y = {name: xyz[axis] for name, xyz in at.items()}
    sides = {p.name: ("left" if y[p.name] > 0 else "right") for p in parts if abs(y[p.name]) > SIDE_EPS}
    pairs = {}
    for cls in dict.fromkeys(p.cls for p in parts):
        members = [p for p in parts if p.cls == cls and p.name in sides]
        lefts = [p for p in members if sides[p.name] == "left"]
        rights = [p for p in members if sides[p.name] == "right"]
        if not lefts or not rights:
            for p in members:
                sides.pop(p.name)  # no mirrored pair: no side
            continue
        pairs[cls] = (max(lefts, key=lambda p: y[p.name]), min(rights, key=lambda p: y[p.name]))
    if pairs:
        questions = [side_question(cls.lower(), left.joints, right.joints) for cls, (left, right) in pairs.items()]
        for (cls, (_left, right)), q, verdict in zip(pairs.items(), questions, ask(oracle, questions, "sides", progress)):
            names_say_flipped = verdict.answer == q.options[1] and verdict.confidence >= NAMES_WIN
            if axis != 1 and verdict.confidence < NAMES_WIN:
                log(f"sides of {cls}: paired across axis {'xyz'[axis]}, the names do not say which is left")
                for p in parts:
                    if p.cls == cls:
                        sides.pop(p.name, None)
            elif names_say_flipped:
                log(f"sides of {cls}: names say {right.joints[0]} is left ({verdict.confidence:.2f})"
                    + (", against geometry: names win" if axis == 1 else f" (paired across axis {'xyz'[axis]})"))
                for p in parts:
                    if p.cls == cls and p.name in sides:
                        sides[p.name] = "right" if sides[p.name] == "left" else "left"
    return [replace(p, side=sides.get(p.name)) for p in parts]


def _lateral_axis(parts: list[BodyPart], at: dict[str, Vector]) -> int:
    """The root axis parts pair across: y, unless no class has parts on both sides of it and the classes whose
    parts are mirror images (within MIRROR_EPS) across x or across z all pair across the same one."""
    def across(axis: int) -> bool:
        return any(a.cls == b.cls and at[a.name][axis] > SIDE_EPS and mirrored(at[a.name], at[b.name], axis)
                   for a in parts for b in parts)
    if any(at[a.name][1] > SIDE_EPS and at[b.name][1] < -SIDE_EPS for a in parts for b in parts if a.cls == b.cls):
        return 1
    found = [axis for axis in (0, 2) if across(axis)]
    return found[0] if len(found) == 1 else 1


def _mean_position(tree: KinematicTree, links: list[str]) -> Vector:
    points = [tree.position_in(link, tree.root) for link in links]
    return (sum(p[0] for p in points) / len(points), sum(p[1] for p in points) / len(points),
            sum(p[2] for p in points) / len(points))


def _anchor(tree: KinematicTree, part: BodyPart) -> list[str]:
    """The links whose position tells a part's side: its joints' child links (a base: its chassis)."""
    edges = {e.joint: e for e in tree.edges}
    return [edges[j].child for j in part.joints] or list(part.links[:1])


def locate(tree: KinematicTree, comp: Component, parts: list[BodyPart]) -> Component:
    """The body part carrying a component's mount (the nearest part up its chain), and that part's side."""
    owner = {link: p for p in parts for link in p.links}
    part = next((owner[a] for a in tree.chain_to_root(comp.root) if a in owner), None)
    if part is None:
        return comp
    return replace(comp, located_on=part.name, side=part.side)
