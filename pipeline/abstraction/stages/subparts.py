"""Stage 7, sub-part typing: every member link of a device typed in its kind's Subpart branch.

A device whose class ontologies/shapes.ttl requires a part of (a camera: an optical frame; a sensor
forming no images: a sensing element) has one at each of its sub-chains' leaves: a sensor chain runs
from its mount to the frame its measurements are expressed in, and nothing hangs below that frame.
Those leaves are refined below the required part (core:partQuestion asks which kind, where it has
kinds); the device's other links are typed with that part's branch ruled out, a tool's links
with what its finger chains rule out (core:fingerChainRole), and a drawn link with the classes of bare frames
(core:frameOnly: a tool centre point) ruled out. Alike links asked the same are asked once.
A device of several sub-chains has its required parts typed first (required_parts_first), before its own
class, which they then narrow (the frames say the camera, not the camera the frames); those answers are
kept here where the class the device got still allows them.
"""
from __future__ import annotations

from urdfkb.pipeline.abstraction.frames import is_frame
from urdfkb.pipeline.reading.evidence import SimSensor, named
from urdfkb.pipeline.knowledge.ontology import Kind, Vocabulary
from urdfkb.pipeline.abstraction.oracle import Oracle
from urdfkb.pipeline.abstraction.stages.asking import Progress
from urdfkb.pipeline.abstraction.stages.classification import Subject, Typed, descend
from urdfkb.pipeline.abstraction.stages.grouping import DEPTH_IMAGES, Group
from urdfkb.pipeline.abstraction.alike import alike_sets
from urdfkb.pipeline.abstraction.structure import ToolStructure
from urdfkb.pipeline.reading.tree import Edge, KinematicTree


def type_subparts(oracle: Oracle, tax: Vocabulary, tree: KinematicTree, kind: Kind, groups: list[Group],
                  classes: list[Typed], structures: list[ToolStructure] | None = None,
                  progress: Progress | None = None, known: dict[str, Typed] | None = None,
                  frozen_tips: frozenset[str] = frozenset()) -> dict[str, Typed]:
    """Each member link of `groups` (devices of `kind`, classified as `classes`) → its sub-part class;
    `structures`: the tools' structures (end-effectors only); `known`: required parts typed before the device
    was (required_parts_first), kept; `frozen_tips`: tips of fingers written fixed (hands.frozen_fingertips)."""
    needed = _required_links(tax, groups, classes)
    kept = {link: t for link, t in (known or {}).items()
            if link in needed and t.cls not in tax.excluded_parts(needed[link])}  # still fits its device's class
    required = {link: cls for link, cls in needed.items() if link not in kept}
    framing = "What role does the link below play in its %s device? Choose the {concept}." % kind.noun
    structural = _structural_parts(tax, tree, kind, groups, structures, frozen_tips)
    drawn = tax.frame_only()  # what a drawn link is not
    rest = [
        (link, Subject(f"part:{link}", framing,
                       f"Link: {named(tree.evidence, link)}\nDevice: {tax.label(t.cls)}",
                       tax.excluded_parts(t.cls) | _required_branch(tax, t.cls) | structural.get(link, frozenset())
                       | (frozenset() if is_frame(tree, link) else drawn)))
        for g, t in zip(groups, classes) for link in g.members if link not in needed
    ]
    frames: dict[str, list[tuple[str, Subject]]] = {}  # required part → its links' subjects
    for link, device in required.items():
        part = tax.required_part(device)
        if part is None:
            raise ValueError(f"{device} requires no sub-part, yet {link} is typed as its required one")
        frames.setdefault(part, []).append((link, _required_subject(tax, tree, link, device, part,
                                                                     tax.excluded_parts(device))))
    typed = _descend_alike(oracle, tax, tree, kind.subparts, rest, "sub-part classification", progress)
    for part, subjects in frames.items():
        typed.update(_descend_alike(oracle, tax, tree, part, subjects, "required parts", progress))
    return typed | kept


def required_parts_first(oracle: Oracle, tax: Vocabulary, tree: KinematicTree, leaves: list[str], device: str,
                         progress: Progress | None = None, typed_as: dict[str, str] | None = None) -> dict[str, Typed]:
    """The kind of the part a `device` class requires (a camera: an optical frame) at each of `leaves`, asked
    before the device's own class, with nothing ruled out: what the frames are then says which classes the
    device can be (Vocabulary.unfit). Empty when that part has no kinds to choose among. A leaf `typed_as` a
    class under `device` already (a lone frame's pre-class) is asked as type_subparts asks it, so its answer is
    the one sub-part typing would get."""
    part = tax.required_part(device)
    if part is None or not tax.subclasses(part):
        return {}
    typed_as = typed_as or {}
    subjects = [(leaf, _required_subject(tax, tree, leaf, typed_as.get(leaf, device), part,
                                         tax.excluded_parts(typed_as[leaf]) if leaf in typed_as else frozenset()))
                for leaf in leaves]
    return _descend_alike(oracle, tax, tree, part, subjects, "required parts", progress)


def _required_subject(tax: Vocabulary, tree: KinematicTree, link: str, device: str, part: str,
                      exclude: frozenset[str]) -> Subject:
    """Which kind of `part` (the part a `device` requires) `link` is, without `exclude` and the kinds the simulator
    sensors declared on it rule out (`_undeclared`), where some kind is left."""
    declared = exclude | _undeclared(tax, tree, link, part)
    if set(tax.subclasses_below(part)) - declared:
        exclude = declared
    holder = tax.label(tax.requiring_class(device) or device)
    return Subject(f"part:{link}", tax.part_question(part) or "The link below is the {concept} of its device: which kind?",
                   f"Link: {named(tree.evidence, link)}\n{holder[:1].upper() + holder[1:]}: {tax.label(device)}", exclude)


def _undeclared(tax: Vocabulary, tree: KinematicTree, link: str, part: str) -> frozenset[str]:
    """The kinds of `part` no simulator sensor declared on `link` gives: each gives those its type allows
    (core:simulatorSensorType on the kinds: a wide-angle camera gives no depth image) and, for a camera stating
    its pixel format, that format allows (core:pixelFormat: an L8 image is no colour one; a depth sensor's format
    is only its preview's)."""
    kinds = set(tax.subclasses_below(part))
    given: set[str] = set()
    for sensor in tree.evidence[link].sensors if link in tree.evidence else ():
        images = image_kinds(tax, sensor, part)
        if images is None:
            return frozenset()  # a declaration saying nothing of images (an IMU's, a ranger's) allows every kind
        given |= images
    return frozenset(kinds - given) if given else frozenset()  # none given: they contradict, the model decides


def image_kinds(tax: Vocabulary, sensor: SimSensor, part: str) -> frozenset[str] | None:
    """The kinds of `part` (a camera's optical frame) a simulator sensor's images may be: those its type allows
    (core:simulatorSensorType on the kinds: a wide-angle camera gives no depth image) and, for a camera stating its
    pixel format, that format allows (core:pixelFormat: an L8 image is no colour one; a depth sensor's format is
    only its preview's). None for a declaration saying nothing of images (an IMU's, a ranger's)."""
    kinds = frozenset(tax.subclasses_below(part))
    declared = tax.declared_classes([sensor.sdf_type])
    if not declared & kinds:
        return None
    typed = tax.disagreeing(declared, part)
    formatted = tax.unformatted([sensor.pixels] if sensor.pixels and sensor.sdf_type not in DEPTH_IMAGES else [], part)
    return kinds - typed - formatted


def _descend_alike(oracle: Oracle, tax: Vocabulary, tree: KinematicTree, start: str,
                   subjects: list[tuple[str, Subject]], stage: str, progress: Progress | None) -> dict[str, Typed]:
    """Each link's class below `start`; alike links (alike.alike_leaves: the same link of a left and a
    right gripper) asked the same about the same kind of device are asked once, the first standing for all."""
    by_link = dict(subjects)
    sets = alike_sets(tree, list(by_link), lambda a, b: _same_question(by_link[a], by_link[b]))
    answers = descend(oracle, tax, start, [by_link[links[0]] for links in sets], stage, progress)
    return {link: typed for links, typed in zip(sets, answers) for link in links}


def _same_question(a: Subject, b: Subject) -> bool:
    """The two subjects differ in their link's name at most (the first line of their evidence)."""
    return (a.framing, a.exclude, a.evidence.split("\n", 1)[1:]) == (b.framing, b.exclude, b.evidence.split("\n", 1)[1:])


def _required_links(tax: Vocabulary, groups: list[Group], classes: list[Typed]) -> dict[str, str]:
    """The leaf of each sub-chain of a device whose class requires a part → the device's class."""
    return {chain.leaf: t.cls for g, t in zip(groups, classes) if tax.required_part(t.cls) is not None
            for chain in g.chains}


def _required_branch(tax: Vocabulary, cls: str) -> frozenset[str]:
    """The branch of the part a `cls` device requires (typed separately), or nothing."""
    part = tax.required_part(cls)
    return tax.branch(part) if part else frozenset()


def _structural_parts(tax: Vocabulary, tree: KinematicTree, kind: Kind, groups: list[Group],
                      structures: list[ToolStructure] | None, frozen_tips: frozenset[str] = frozenset()
                      ) -> dict[str, frozenset[str]]:
    """Sub-part classes a tool's structure rules out for its links (core:fingerChainRole): a link of
    a finger chain is a finger or its contact surface, and only the latter where it is a leaf fixed to the
    finger (a pad or tip frame: a finger is jointed); so is a link moved by a joint that does not spin in a
    tool with no finger chain (the jaw of a one-jaw gripper, closing against the fixed body; a spindle or
    rotor spins: Edge.spins; a bare frame has nothing to close with), a link nothing moves that is shaped as such
    a finger or jaw (_fixed_jaws: the fixed jaw of a one-jaw gripper), and a link of a finger written fixed (from a
    frozen tip up to the body its fingers part from) is a finger or its contact surface; any other link is no finger,
    nor a palm if it is a leaf (nothing extends from it) or the tool has fingers and none hangs from it.
    (Nothing for sensors.)"""
    if structures is None:
        return {}
    finger, carrier, tip = (tax.finger_chain_role(role) for role in ("link", "carrier", "tip"))
    on_finger = frozenset(set(tax.subclasses_below(kind.subparts)) - finger - tip)
    excluded = {}
    for group, structure in zip(groups, structures):
        frozen = {link for tip in frozen_tips if tip in group.members for link in _frozen_finger(tree, tip)}
        fingers = {link for f in structure.fingers for link in f.links} | frozen
        jaws = set() if fingers else {link for link in group.members if _jaw(tree, link, structure.mount)}
        fixed_jaws = _fixed_jaws(tree, group.members, fingers | jaws, structure.mount)
        carriers = {link for f in structure.fingers for link in tree.chain_to_root(f.name)[1:]}
        for link in group.members:
            if link in fingers or link in jaws or link in fixed_jaws:
                fixed_tip = tree.is_leaf(link) and not tree.edge_to(link).movable and link not in frozen | fixed_jaws
                excluded[link] = on_finger | (finger if fixed_tip else frozenset())
            elif (fingers and link not in carriers) or tree.is_leaf(link):
                excluded[link] = finger | carrier
            else:
                excluded[link] = finger
    return excluded


def _frozen_finger(tree: KinematicTree, tip: str) -> list[str]:
    """The links of a finger written fixed: its tip and each link above that carries nothing else."""
    links = [tip]
    while (parent := tree.parent(links[-1])) is not None and len(tree.children(parent)) == 1:
        links.append(parent)
    return links


def _joints_from(tree: KinematicTree, mount: str, link: str) -> list[Edge] | None:
    """The joints between `mount` and `link` (None where `mount` is not above it)."""
    path = tree.chain_to_root(link)
    return [tree.edge_to(x) for x in path[:path.index(mount)]] if mount in path else None


def _jaw(tree: KinematicTree, link: str, mount: str) -> bool:
    """A movable joint that does not spin lies between `mount` and `link`, and the link or something below it has a
    body to close with (a bare frame turning on its own joint is a reference, not a jaw)."""
    joints = _joints_from(tree, mount, link)
    return joints is not None and any(e.movable and not e.spins for e in joints) \
        and not all(is_frame(tree, x) for x in (link, *tree.descendants(link)))


def _fixed_jaws(tree: KinematicTree, members: list[str], moving: set[str], mount: str) -> set[str]:
    """The drawn members no joint of the tool moves that are shaped as one of its moving fingers or jaws is (the
    same meshes, or the same primitive where neither has a mesh): the fixed jaw a moving one closes against."""
    def shape(link: str) -> tuple[tuple[str, ...], str] | None:
        facts = tree.evidence.get(link)
        return None if facts is None or is_frame(tree, link) else (facts.meshes, "" if facts.meshes else facts.shape)

    def fixed(link: str) -> bool:
        joints = _joints_from(tree, mount, link)
        return joints is not None and not any(e.movable for e in joints)
    shapes = {s for link in moving if (s := shape(link)) is not None}
    return {link for link in members if fixed(link) and (s := shape(link)) is not None and s in shapes}
