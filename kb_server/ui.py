"""The browser pages of `urdfkb serve`, rendered (Jinja2 templates, plain JavaScript, every asset served locally).

The routes serve them (kb_server/routes/): `/` (routes/pages.py) lists the robots and uploads a URDF or
xacro file; `/robots/<name>` for clients asking for HTML (routes/robots.py) draws the tree with the body
parts and components, and lists both with review controls and what they can do (a camera's optical
frames and field of view, an arm's reach); `/sparql` with no query (routes/sparql.py)
is a query editor. A browser's GET that fails gets an error page (kb_server.replies.handle_error).
"""
from __future__ import annotations

import math

from flask import Response, render_template, request

from urdfkb import local_name
from urdfkb.kb_server import corrections as review
from urdfkb.kb_server import body_view, palette, queries, tree_svg
from urdfkb.kb_server.body_corrections import SIDE_CHOICES
from urdfkb.kb_server.store import Store
from urdfkb.pipeline.knowledge.formats import RESULTS_MEDIA
from urdfkb.pipeline.knowledge.namespaces import component_iri
from urdfkb.pipeline.knowledge.ontology import vocabulary
from urdfkb.settings import REVIEW_THRESHOLD

JSON_TYPES = tuple(media for media, f in RESULTS_MEDIA.items() if f.name == "json")  # what API clients ask for


def wants_html() -> bool:
    """True when the client prefers HTML over JSON (browsers), False for API clients and */*."""
    accept = request.accept_mimetypes
    return "text/html" in accept.values() and accept.best_match((*JSON_TYPES, "text/html")) == "text/html"


def robot_page(store: Store, name: str) -> str:
    """The robot's page: SVG tree, components least confident first, review controls, what the shapes held
    back (pipeline.knowledge.screen) (UnknownRobot if there is no such robot: kb_server.replies answers it as a page)."""
    entry = store.require(name)
    reviewed = store.reviewed(name)  # kept between writes of the robot: never computed again for a page
    tree, model, corrected, report = reviewed.tree, reviewed.model, reviewed.corrected, reviewed.report
    comps = queries.components(store, name)
    body = body_view.rows(tree, corrected, report)
    corrected_comps = {component_iri(entry.ontology_iri, c.name): c for c in corrected.components}
    influenced: dict[str, list[dict]] = {}
    for corr, comp_name in report.applied:
        if isinstance(corr, review.Correction):
            influenced.setdefault(component_iri(entry.ontology_iri, comp_name), []).append(corr.to_dict())
    stale = [{**c.to_dict(), "reason": why} for c, why in report.stale]
    rows = []
    for c in comps:
        links = tuple(s["link"] for s in c["subcomponents"] if s.get("link"))
        kind = review.kind_of(c["class"]) or "other"
        comp = corrected_comps.get(c["iri"])
        notes = influenced.get(c["iri"], [])
        rows.append({
            **c, "key": local_name(c["iri"]), "kind": kind, "links": links,
            "classes": review.allowed_classes(comp) if comp else (),
            "mounts": review.mount_options(tree, links) if links else (),
            "reviews": notes, "confirmed": any(n["action"] == "confirm" for n in notes),
            "added": any(n["action"] == "add" for n in notes)})
    sights, reaches = _capabilities(store, name)
    for r in rows:
        r["sight"] = sights.get(r["iri"])
    for p in body:
        p["reach"] = reaches.get(p["key"])
    rows.sort(key=lambda r: (r["confidence"] if r["confidence"] is not None else 1.0, r["key"]))
    outlines = [tree_svg.Outline(r["key"], f"{r['class']} ({r['confidence']:.2f})" if r["confidence"] is not None
                                 else r["class"], palette.kind_colour(r["kind"]), r["links"], r["mount"],
                                 (r["confidence"] or 0) < REVIEW_THRESHOLD and not r["confirmed"]) for r in rows]
    vocab = vocabulary()
    addable = [c for kind in vocab.kinds.values() for c in (kind.cls, *vocab.subclasses_below(kind.cls))]
    claimed = {link for r in rows for link in r["links"]}
    return render_template("robot.html", entry=entry, rows=rows, svg=tree_svg.render(tree, outlines, body_view.bands(body)),
                           stale=stale, held=model.held, links=tree.links, claimed=claimed,
                           addable=addable, body=body, body_legend=body_view.legend(body), sides=SIDE_CHOICES)


def error_page(status: int, message: str) -> Response:
    """The page a browser gets for an error (kb_server.replies.handle_error): the message and a way back."""
    page = render_template("error.html", status=status, message=message)
    return Response(page.encode("utf-8", "backslashreplace"), status, mimetype="text/html")


def _capabilities(store: Store, name: str) -> tuple[dict[str, dict], dict[str, dict]]:
    """What the page shows of what parts can do (the camera_frames and arm_reach queries): per camera IRI its
    optical frames (link, modality) and declared field of view (degrees) and image size; per arm (its
    individual's local name) its reach (m) and degrees of freedom."""
    sights: dict[str, dict] = {}
    for row in queries.run_named(store, "camera_frames", name, {}).as_dicts():
        sight = sights.setdefault(row["camera"], {
            "frames": [], "fov": math.degrees(float(row["fov"])) if "fov" in row else None,
            "image": f"{row['width']}×{row['height']}" if "width" in row and "height" in row else None})
        sight["frames"].append({"link": row["frame"], "modality": row.get("modalityLabel") or local_name(row["modality"])})
    reaches = {local_name(row["arm"]): {"reach": float(row["reach"]) if "reach" in row else None,
                                               "dof": row.get("degreesOfFreedom")}
               for row in queries.run_named(store, "arm_reach", name, {}).as_dicts()}
    return sights, reaches


def sparql_page() -> str:
    """The query editor, offering each bundled query with its defaults filled in ($robot left free)."""
    offered = []
    for q in queries.load_queries().values():
        text = q.text
        for p in q.params:
            text = text.replace(f"${p.name}", p.term(p.default).n3() if p.default is not None else f"?{p.name}")
        offered.append({"name": q.name, "title": q.title, "text": text.replace("$robot", "?robot")})
    return render_template("sparql.html", queries=offered)
