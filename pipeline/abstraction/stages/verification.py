"""Stage 5, abstraction verification (deterministic): no member of a group has a child outside it.

When a member has a child outside its group, one of two repairs applies, and the trace says which:
- absorb: the outside subtree holds no link claimed by any component (every leaf in it was
  identified as none of the component kinds, and no device is mounted in it): it is physically
  carried by the device, so its links join the group;
- re-root: otherwise the member is really a body link carrying other things, so it becomes the
  mount of the sub-chains through it, which keep only the links below it.
Repairs repeat until every group is closed; a group whose sub-chains end up on different mounts
is split into one group per mount.
"""
from __future__ import annotations

import re
from typing import Callable

from urdfkb.pipeline.reading.tree import KinematicTree
from urdfkb.pipeline.abstraction.stages.attachment import sub_chain
from urdfkb.pipeline.abstraction.stages.grouping import Group

Log = Callable[[str], None]


def group_root(tree: KinematicTree, group: Group) -> str | None:
    """The single link outside the group that carries it, or None if there are several."""
    members = set(group.members)
    tops = {tree.parent(m) for m in members if tree.parent(m) not in members}
    return tops.pop() if len(tops) == 1 else None


def _split_by_mount(tree: KinematicTree, group: Group) -> list[Group]:
    if group_root(tree, group) is not None:
        return [group]
    parts: dict[str, Group] = {}
    for chain in group.chains:
        parts.setdefault(chain.root, Group([])).chains.append(chain)
    # chains mounted inside another part belong to that part
    merged: list[Group] = []
    for root, part in parts.items():
        host = next((p for p in parts.values() if p is not part and root in p.members), None)
        (host.chains.extend(part.chains) if host else merged.append(part))
    return merged


def _offender(tree: KinematicTree, group: Group) -> tuple[str, list[str]] | None:
    members = set(group.members)
    for m in group.members:
        outside = [c for c in tree.children(m) if c not in members]
        if outside:
            return m, outside
    return None


def _absorbable(tree: KinematicTree, outside: list[str], unclaimed: Callable[[str], bool]) -> list[str] | None:
    links = [x for c in outside for x in (c, *tree.descendants(c))]
    return links if all(unclaimed(x) for x in links) else None


def _reroot(tree: KinematicTree, group: Group, member: str) -> None:
    group.chains = [sub_chain(tree, c.leaf, member) if member in c.links else c for c in group.chains]
    group.absorbed = [a for a in group.absorbed if member in tree.chain_to_root(a)[1:]]


def verify(tree: KinematicTree, groups: list[Group], unclaimed: Callable[[str], bool], log: Log) -> list[Group]:
    """Repair every group until closed; `unclaimed(link)` says a link belongs to no component."""
    todo, done = list(groups), []
    while todo:
        group = todo.pop()
        found = _offender(tree, group)
        if found is None:
            parts = _split_by_mount(tree, group)
            if len(parts) > 1:
                log(f"split {group.leaves} by mount into {[p.leaves for p in parts]}")
                todo.extend(parts)
            else:
                done.append(group)
            continue
        member, outside = found
        absorbed = _absorbable(tree, outside, unclaimed)
        if absorbed is not None:
            log(f"absorb {absorbed} into {group.leaves} (carried by {member})")
            group.absorbed.extend(absorbed)
        else:
            log(f"re-root {group.leaves} at {member} (it also carries {outside})")
            _reroot(tree, group, member)
        todo.append(group)
    return sorted(done, key=lambda g: tree.links.index(g.chains[0].leaf))


_INDEX = re.compile(r"\d+")


def indexed_units(tree: KinematicTree, group: Group, named_apart: bool = False) -> bool:
    """True when the group's sub-chains are numbered units of one type: each hangs by its own joint
    from one shared parent, and their top links' names differ only by a number (sonar_1, sonar_2), or, where
    `named_apart`, only in their last word (button_1, button_power)."""
    tops = {c.links[0] for c in group.chains}
    if len(tops) < 2 or len(tops) != len(group.chains) or len({tree.parent(t) for t in tops}) != 1:
        return False
    return len({_INDEX.sub("#", t) for t in tops}) == 1 or (named_apart and _one_stem(tops))


def _one_stem(names: set[str]) -> bool:
    """The names share all but their last word, which tells each apart (button_1, button_2, button_power)."""
    return all("_" in name for name in names) and len({name.rsplit("_", 1)[0] for name in names}) == 1
