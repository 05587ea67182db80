"""The kinematic tree as an SVG, laid out in pure Python (no Graphviz): root on the left, one column
per depth, each leaf on its own row and every parent centred on its children (a tidy tree for a
tree that is one). Components are drawn as coloured outlines around their links, their mount
marked with a dashed tie; body parts as a band of their colour under each of their links (with the
initial of their side, L or R, at its end) and their joints drawn in that colour; every link is
labelled with its URDF name.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from html import escape

from urdfkb.pipeline.reading.tree import KinematicTree

ROW = 22           # px between leaf rows
CHAR = 6.6         # px per character of a 11px monospace label
GAP = 34           # px between columns
PAD = 12
SIDE = 12          # px a sided part's band reaches past a link's box, for the side's initial


@dataclass(frozen=True)
class Outline:
    """One component to draw: its name, colour (its kind's), member links, mount link and whether it is
    low-confidence."""

    key: str
    label: str
    colour: str
    links: tuple[str, ...]
    mount: str | None
    low: bool = False


@dataclass(frozen=True)
class Band:
    """One body part to draw: its name, label, colour, links, joints and side (None: it has none)."""

    key: str
    label: str
    colour: str
    links: tuple[str, ...]
    joints: tuple[str, ...]
    side: str | None = None


def layout(tree: KinematicTree) -> tuple[dict[str, tuple[float, float]], int]:
    """(x of the box's left edge, y of its centre line) of each link, and the number of leaf rows."""
    depth: dict[str, int] = {tree.root: 0}
    dfs, stack = [], [tree.root]
    while stack:  # depth-first, children in URDF order: leaves come out in drawing order
        link = stack.pop()
        dfs.append(link)
        for child in reversed(tree.children(link)):
            depth[child] = depth[link] + 1
            stack.append(child)
    widths: dict[int, float] = {}
    for link, d in depth.items():
        widths[d] = max(widths.get(d, 0), len(link) * CHAR + 10)
    left = {0: float(PAD)}
    for d in range(1, max(widths) + 1):
        left[d] = left[d - 1] + widths[d - 1] + GAP
    y: dict[str, float] = {}
    rows = 0
    for link in dfs:
        if not tree.children(link):
            y[link] = PAD + ROW / 2 + rows * ROW
            rows += 1
    for link in reversed(dfs):  # every parent centred on its first and last child
        kids = tree.children(link)
        if kids:
            y[link] = (y[kids[0]] + y[kids[-1]]) / 2
    return {link: (left[depth[link]], y[link]) for link in tree.links}, rows


def render(tree: KinematicTree, outlines: list[Outline], bands: Sequence[Band] = ()) -> str:
    """The SVG document (a string safe to inline in HTML)."""
    pos, rows = layout(tree)

    def box(link: str) -> tuple[float, float, float, float]:
        x, yc = pos[link]
        return x, yc - 8, len(link) * CHAR + 10, 16

    parts: list[str] = []
    for b in bands:  # bands under everything else
        parts.append(f'<g class="body-part" data-part="{escape(b.key)}"><title>{escape(b.label)}</title>')
        for link in b.links:
            x, y0, w, h = box(link)
            reach = SIDE if b.side else 0
            parts.append(f'<rect x="{x - 3:.1f}" y="{y0 - 3:.1f}" width="{w + 6 + reach:.1f}" height="{h + 6}" rx="4" '
                         f'fill="{b.colour}" fill-opacity="0.5"/>')
            if b.side:
                parts.append(f'<text class="side" x="{x + w + 2:.1f}" y="{y0 + 12:.1f}" fill="{b.colour}">'
                             f'{escape(b.side[0].upper())}</text>')
        parts.append("</g>")
    joint_band = {j: b for b in bands for j in b.joints}
    for o in outlines:  # outlines over the bands, under joints and links
        members = [box(link) for link in o.links if link in pos]
        if not members:
            continue
        x0 = min(b[0] for b in members) - 5
        y0 = min(b[1] for b in members) - 5
        x1 = max(b[0] + b[2] for b in members) + 5
        y1 = max(b[1] + b[3] for b in members) + 5
        dash = ' stroke-dasharray="5 3"' if o.low else ""
        parts.append(f'<g class="component" data-component="{escape(o.key)}"><title>{escape(o.label)}</title>'
                     f'<rect x="{x0:.1f}" y="{y0:.1f}" width="{x1 - x0:.1f}" height="{y1 - y0:.1f}" rx="7" '
                     f'fill="{o.colour}" fill-opacity="0.12" stroke="{o.colour}" stroke-width="2"{dash}/>')
        if o.mount in pos:
            mx, my = pos[o.mount]
            mx += len(o.mount) * CHAR + 10
            parts.append(f'<path d="M{mx:.1f},{my:.1f} C{mx + 20:.1f},{my:.1f} {x0 - 20:.1f},{(y0 + y1) / 2:.1f} '
                         f'{x0:.1f},{(y0 + y1) / 2:.1f}" fill="none" stroke="{o.colour}" stroke-width="1.5" '
                         f'stroke-dasharray="3 3"/>'
                         f'<path class="mount" d="M{mx:.1f},{my - 6:.1f} l6,6 l-6,6 l-6,-6 z" fill="{o.colour}"/>')
        parts.append("</g>")
    for edge in tree.edges:
        px, py = pos[edge.parent]
        cx, cy = pos[edge.child]
        px += len(edge.parent) * CHAR + 10
        mid = (px + cx) / 2
        band = joint_band.get(edge.joint)
        style = f' style="stroke: {band.colour}; stroke-width: 3"' if band else ""
        part = f" of {band.label}" if band else ""
        parts.append(f'<path class="joint" d="M{px:.1f},{py:.1f} C{mid:.1f},{py:.1f} {mid:.1f},{cy:.1f} {cx:.1f},{cy:.1f}"'
                     f'{style}><title>{escape(edge.joint)} ({edge.joint_type}){escape(part)}</title></path>')
    for link in tree.links:
        x, y0, w, h = box(link)
        parts.append(f'<g class="link" data-link="{escape(link)}"><rect x="{x:.1f}" y="{y0:.1f}" width="{w:.1f}" '
                     f'height="{h}" rx="3"/><text x="{x + 5:.1f}" y="{y0 + 12:.1f}">{escape(link)}</text></g>')
    width = max(pos[link][0] + len(link) * CHAR + 10 for link in tree.links) + PAD + 20
    height = PAD * 2 + max(rows, 1) * ROW
    return (f'<svg xmlns="http://www.w3.org/2000/svg" class="tree" width="{width:.0f}" height="{height:.0f}" '
            f'viewBox="0 0 {width:.0f} {height:.0f}" role="img" aria-label="kinematic tree of {escape(tree.robot_name)}">'
            + "".join(parts) + "</svg>")

