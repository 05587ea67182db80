"""Stage 6 for end-effectors: extent and mount by structure, after verification (pipeline.abstraction.structure defines the facts).

The model's mount choices only group a tool's leaves; the tool itself is then settled from the tree:
- a tool sits at the end of an arm: a group whose mount is carried by fewer than two independent
  moving joints (a caster on a base; a joint following another by <mimic> counts the one it follows), or whose mount carries an arm beside the tool (a cover half-way
  up an arm), is no tool; unless nothing moving carries it and its fingers close against each
  other, or every leaf of the robot was identified as its own and not all that moves in it spins freely (a
  vehicle's lone propeller): a gripper, hand or suction cup described on its own;
- a group whose leaves fork above an arm (a child of the fork carries a serial chain of at least
  ARM_JOINTS independent moving joints reaching at least ARM_REACH of the fork's distance from the
  root, and at least ARM_MIN_REACH from its own first joint: an arm, not a finger of four joints) is
  split at that fork;
- a tool in which nothing moves, reaching out from its mount farther than the limb carrying it is long (measured
  from the limb's first moving joint; a limb that slides is not measured so), is no tool but the limb's own segment
  (a forearm fixed to an upper arm that a shoulder's pitch and roll, meeting at one point, swing);
- the tool is mounted on the link it is bolted to (`structure.mount_of`), never on its own palm and
  never above the arm's last moving link: links above that mount leave the tool; where no finger moves and a
  moving chain of the tool turns in place the leaves it carries (a wrist's last roll turning its flange), that
  roll is the arm's, and the tool is what it carries;
- the tool keeps every finger chain and mechanism hung on its fork (a hand keeps its thumb), and
  every static frame on its palm; where the fingers hang straight on the arm's last link (the
  mount), only static frames identified as end-effector parts join;
- groups that end up on one mount are one tool, and so are groups whose chains begin at one point of one body
  (one's mount hung from the other's where a link of the other hangs: a hand written as finger joints beside its
  tool frame on the wrist).
A sensor device found in the sensor pass is no longer in the tree, so it is never part of a tool;
the link it is mounted on may be (a camera on a palm).
"""
from __future__ import annotations

import math
from typing import Callable

from urdfkb.pipeline.abstraction.frames import is_frame, meeting_tips
from urdfkb.pipeline.abstraction.hands import ROLL_OFFSET, limb_length, limb_top
from urdfkb.pipeline.abstraction.vectors import off_axis, unit
from urdfkb.pipeline.abstraction.structure import ToolStructure, nothing_moves, source_joint, tool_structure
from urdfkb.pipeline.reading.tree import KinematicTree, fork_of
from urdfkb.pipeline.abstraction.stages.attachment import sub_chain
from urdfkb.pipeline.abstraction.stages.grouping import Group
from urdfkb.pipeline.abstraction.stages.verification import Log

ARM_JOINTS = 4  # independent moving joints in series that make an arm, if long enough (ARM_REACH)
ARM_REACH = 0.5  # share of the distance from the root that a chain of ARM_JOINTS must reach to be an arm
ARM_MIN_REACH = 0.2  # m from its first joint, and at least this: farther than a wrist with its hand or any finger reaches


def settle(tree: KinematicTree, groups: list[Group], part_of_tool: Callable[[str], bool],
           log: Log) -> list[tuple[Group, ToolStructure]]:
    """Split, re-mount and complete verified tool groups; `part_of_tool(leaf)`: the leaf was identified
    as part of an end-effector."""
    pending: list[list[str]] = [part for g in groups for part in _split_arms(tree, _tool_leaves(tree, g), log)]
    done: list[tuple[list[str], ToolStructure, set[str]]] = []
    while pending:
        leaves = pending.pop(0)
        structure = tool_structure(tree, leaves)
        if beyond := _beyond_roll(tree, structure, leaves):
            log(f"{[x for x in leaves if x not in beyond]} hang before {beyond}'s roll, the arm's last joint")
            pending.insert(0, beyond)
            continue
        links = _extent(tree, structure, leaves, part_of_tool)
        clash = [d for d in done if set(d[0]) & links or set(leaves) & d[2] or d[1].mount == structure.mount
                 or _hung_together(tree, (d[1].mount, d[2]), (structure.mount, links))]
        if clash:  # this group lies on a tool already settled, or that tool on it: one tool, settled again
            done = [d for d in done if d not in clash]
            pending.append(leaves + [x for d in clash for x in d[0] if x not in leaves])
            continue
        done.append((leaves, structure, links))
    settled = []
    for leaves, structure, links in done:
        mount = structure.mount
        alone = _joints_above(tree, mount) == 0 and (structure.grasps() or set(tree.leaves()) <= set(leaves)
                                                     and not _only_spins(tree, links))
        if (_joints_above(tree, mount) < 2 and not alone) or any(
                _carries_arm(tree, child) for child in tree.children(mount) if child not in links):
            log(f"no tool: {leaves} mounted on {mount}, which is not the end of an arm")
            continue
        if nothing_moves(tree, structure, mount) and _limb_segment(tree, mount, links):
            log(f"no tool: {leaves} reach out from {mount} farther than the limb carrying it is long (its segment)")
            continue
        tool_leaves = [link for link in tree.links if link in links and tree.is_leaf(link)]
        group = Group([sub_chain(tree, leaf, mount) for leaf in tool_leaves])
        group.absorbed = [link for link in tree.links if link in links and link not in set(group.members)]
        added = [x for x in tool_leaves if x not in leaves]
        log(f"tool {tool_leaves} mounted on {mount} (fork {structure.fork}): {structure.describe()}"
            + (f"; joined by structure: {added}" if added else ""))
        settled.append((group, structure))
    return sorted(settled, key=lambda gs: tree.links.index(gs[0].chains[0].leaf))


def _beyond_roll(tree: KinematicTree, structure: ToolStructure, leaves: list[str]) -> list[str]:
    """Where no finger of the tool moves and one of its moving chains turns in place the leaves it carries (one
    joint, those leaves fixed beyond its first link within ROLL_OFFSET of that joint's axis: a wrist's last roll
    turning a flange), those leaves, when other leaves hang before it; else none. A jaw swings its tip about a
    hinge across it."""
    if structure.fingers:
        return []
    for first in structure.mechanisms:
        below, axis = tree.descendants(first), unit(tree.edge_to(first).axis)
        carried = [x for x in leaves if x in below]
        if carried and len(carried) < len(leaves) and axis is not None \
                and not any(tree.edge_to(x).movable for x in below) \
                and all(off_axis(tree.position_in(x, first), axis) <= ROLL_OFFSET for x in carried):
            return carried
    return []


def _only_spins(tree: KinematicTree, links: set[str]) -> bool:
    """Every joint that moves in the tool spins freely (Edge.spins), one at least: a rotor, a propeller or a wheel
    turning on a body that nothing moves, not a tool described on its own."""
    moving = [tree.edge_to(link) for link in links if tree.edge_to(link).movable]
    return bool(moving) and all(edge.spins for edge in moving)


TOGETHER = 0.005  # m: links hung this close together on one body begin one tool (frames.body_of's 5 mm)


def _hung_together(tree: KinematicTree, a: tuple[str, set[str]], b: tuple[str, set[str]]) -> bool:
    """One tool's mount hangs from the other's at the point where a bare frame of that other tool hangs from it
    (each: its mount and its links): the chains of one tool beginning at one point, beside its tool frame (a hand
    whose finger joints and tool frame are written side by side on the wrist). Not beside a body of the other tool
    (a gripper's palm with a suction slide next to it: two tools on one flange), nor on a limb beyond it."""
    for (mount, links), (other, _) in ((a, b), (b, a)):
        edge = tree.parent_edge(other)
        if edge is None or edge.parent != mount:
            continue
        at = tree.position_in(other, mount)
        if any(math.dist(tree.position_in(link, mount), at) <= TOGETHER and is_frame(tree, link)
               for link in tree.children(mount) if link != other and link in links):
            return True
    return False


def _tool_leaves(tree: KinematicTree, group: Group) -> list[str]:
    """The group's leaves and the tips they meet across the one joint that opens them (frames.meeting_tips: a fixed
    jaw's tip frame where the moving jaw's closes on it). A sensor is out of the tree by now, so those are the tool's,
    and tell where its fingers part."""
    return list(dict.fromkeys(group.leaves + [tip for leaf in group.leaves for tip in meeting_tips(tree, leaf)]))


def _split_arms(tree: KinematicTree, leaves: list[str], log: Log) -> list[list[str]]:
    """The leaves, or the leaves split by the fork's children when one of them carries an arm."""
    if len(leaves) < 2:
        return [leaves]
    fork = fork_of(tree, leaves)
    if not any(_carries_arm(tree, child) for child in tree.children(fork)):
        return [leaves]
    parts: dict[str, list[str]] = {}
    for leaf in leaves:
        path = tree.chain_to_root(leaf)
        parts.setdefault(path[path.index(fork) - 1] if leaf != fork else leaf, []).append(leaf)
    log(f"split {leaves} at {fork}: an arm hangs below it")
    return [p for part in parts.values() for p in _split_arms(tree, part, log)]


def _joints_above(tree: KinematicTree, link: str) -> int:
    """The joints moving on their own that move `link`: between the tree's root and `link`, its own included, each
    moving joint counts the joint at the root of its <mimic> chain (itself where it follows none), once (a parallel
    arm's elbow and wrist follow the motors of its linkage beside them)."""
    edges = (tree.edge_to(x) for x in tree.chain_to_root(link)[:-1])
    return len({source_joint(tree, e).joint for e in edges if e.movable})


def _carries_arm(tree: KinematicTree, top: str) -> bool:
    """`top` and what hangs below it make an arm: a serial chain of at least ARM_JOINTS independent
    moving joints that reaches at least ARM_REACH of the distance from the tree's root to `top`'s parent
    (a finger of four joints, as on many hands, is short beside the arm that carries it), and at least
    ARM_MIN_REACH from `top` (where nothing carries the hand, there is no arm to compare with)."""
    if _serial_joints(tree, top) < ARM_JOINTS:
        return False
    parent = tree.edge_to(top).parent
    below = (top, *tree.descendants(top))
    reach = max(_norm(tree.position_in(link, parent)) for link in below)
    length = max(_norm(tree.position_in(link, top)) for link in below)
    return reach >= ARM_REACH * _norm(tree.position_in(parent, tree.root)) and length >= ARM_MIN_REACH


def _limb_segment(tree: KinematicTree, mount: str, links: set[str]) -> bool:
    """Links fixed to `mount` reach out from it farther than the limb carrying it is long, measured from the limb's
    first moving joint down to the mount (the sum of the joint offsets between; the limb starts below the first
    link above that carries another moving chain, or the root; static frames hung along it do not end it): a rigid
    body swung by joints that meet at one point, as an upper arm by its shoulder's pitch and roll, is the limb's own
    segment. A tool is small beside the arm that carries it. Not on a limb with a sliding joint, whose travel is
    no offset."""
    path = tree.chain_to_root(mount)
    top = path.index(limb_top(tree, mount))
    moving = [i for i in range(top) if tree.edge_to(path[i]).movable]
    if not moving or any(tree.edge_to(path[i]).joint_type == "prismatic" for i in moving):
        return False  # a sliding joint carries the tool farther than its offset says (a gantry's spindle)
    return max(_norm(tree.position_in(link, mount)) for link in links) > limb_length(tree, mount, path[moving[-1]])


def _norm(v) -> float:
    return math.sqrt(sum(x * x for x in v))


def _serial_joints(tree: KinematicTree, top: str) -> int:
    """Most independent moving joints (no <mimic>) on one path from `top` (its own joint included) down."""
    def count(link: str) -> int:
        own = int(tree.edge_to(link).independent)
        return own + max((count(c) for c in tree.children(link)), default=0)
    return count(top)


def _extent(tree: KinematicTree, structure: ToolStructure, leaves: list[str],
            part_of_tool: Callable[[str], bool]) -> set[str]:
    """The tool's links: the fork's branch below the mount, closed downwards (module docstring)."""
    fork, mount = structure.fork, structure.mount
    moving = {f.name for f in structure.fingers} | set(structure.mechanisms)
    links: set[str] = set()
    for child in tree.children(mount):
        branch = (child, *tree.descendants(child))
        if fork != mount and fork not in branch:
            continue  # the mount carries other things beside the tool
        if fork == mount and not _hangs_moving(tree, branch, moving) and not any(
                part_of_tool(x) or x in leaves for x in branch if tree.is_leaf(x)):
            continue  # a static frame on the arm's last link that was not called part of the tool
        links.update(branch)
    return links


def _hangs_moving(tree: KinematicTree, branch: tuple[str, ...], moving: set[str]) -> bool:
    return any(link in moving for link in branch)
