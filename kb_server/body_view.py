"""The body on the robot page: a row per body part (what it is, what is on it, its reviews and review
choices), the bands the tree draws for them and their legend."""
from __future__ import annotations

from urdfkb.kb_server import body_corrections as body
from urdfkb.kb_server import palette, tree_svg
from urdfkb.kb_server.corrections import BodyCorrection, Report
from urdfkb.pipeline.abstraction.components import Abstraction
from urdfkb.pipeline.knowledge.namespaces import body_part_local, component_local
from urdfkb.pipeline.reading.tree import KinematicTree


def rows(tree: KinematicTree, corrected: Abstraction, report: Report) -> list[dict]:
    """Each body part with class, side, mount, joints, links, the components located on it, the corrections
    that changed it, and what a reviewer may choose: its class, the parts it may merge with, where to split it."""
    located: dict[str | None, list[dict]] = {}
    for c in corrected.components:
        located.setdefault(c.located_on, []).append({"name": c.name, "class": c.cls, "key": component_local(c.name)})
    reviews: dict[str, list[dict]] = {}
    for corr, name in report.applied:
        if isinstance(corr, BodyCorrection):
            reviews.setdefault(name, []).append(corr.to_dict())
    parts = list(corrected.body)
    return [{"name": p.name, "key": body_part_local(p.name), "class": p.cls, "side": p.side, "mount": p.root,
             "joints": p.joints, "links": p.links, "parent": p.parent, "swatch": palette.body_swatch(p.cls),
             "located": located.get(p.name, []), "reviews": reviews.get(p.name, []), "classes": body.classes(),
             "touching": [t.name for t in body.touching(parts, p)], "splits": body.split_points(tree, p)}
            for p in parts]


def bands(parts: list[dict]) -> list[tree_svg.Band]:
    return [tree_svg.Band(p["key"], f"{p['class']} {p['name']}" + (f" ({p['side']})" if p["side"] else ""),
                          p["swatch"].colour, p["links"], p["joints"], p["side"]) for p in parts]


def legend(parts: list[dict]) -> list[palette.Swatch]:
    """The swatches of the classes the robot's parts have, once each."""
    return list(dict.fromkeys(p["swatch"] for p in parts))
