"""The browser pages of `urdfkb serve` (Jinja2 templates, plain JavaScript, every asset served locally).

`/` lists the robots and uploads a URDF or xacro file; `/robots/<name>` (for clients asking for
HTML) draws the tree with the body parts and components, and lists both with review controls;
`/sparql` (HTML, no query) is a query editor. `GET/POST /robots/<name>/corrections` list and add
reviewers' corrections (of components and of body parts).
"""
from __future__ import annotations

from collections import Counter
from typing import Callable

from flask import Blueprint, Response, jsonify, render_template, request

from urdfkb.kb_server import corrections as review
from urdfkb.kb_server import body_view, palette, queries, tree_svg
from urdfkb.kb_server.body_corrections import SIDE_CHOICES
from urdfkb.kb_server.jobs import JobManager
from urdfkb.kb_server.store import Store
from urdfkb.pipeline.formats import RESULTS_MEDIA
from urdfkb.pipeline.namespaces import CORE_IRI, component_iri
from urdfkb.pipeline.ontology import vocabulary
from urdfkb.pipeline.runner import Settings
from urdfkb.pipeline.tree import KinematicTree

JSON_TYPES = tuple(media for media, f in RESULTS_MEDIA.items() if f.name == "json")  # what API clients ask for


def wants_html() -> bool:
    """True when the client prefers HTML over JSON (browsers), False for API clients and */*."""
    accept = request.accept_mimetypes
    return "text/html" in accept.values() and accept.best_match((*JSON_TYPES, "text/html")) == "text/html"


def blueprint(store: Store, jobs: JobManager, may_write: Callable[[], bool],
              error: Callable[[int, str], Response]) -> Blueprint:
    """The index page, the corrections routes and re-populating a stored robot; `may_write()` says
    whether this request may correct or populate, `error(status, message)` builds the app's refusals."""
    bp = Blueprint("ui", __name__)

    @bp.get("/")
    def index():
        robots = []
        for entry in store.robots():
            comps = queries.components(store, entry.name)
            low = queries.run_named(store, "low_confidence", entry.name, {})
            kinds = Counter(review.kind_of(c["class"]) or "other" for c in comps)
            robots.append({"name": entry.name, "updated": entry.updated, "kinds": kinds, "low": len(low.bindings())})
        return render_template("index.html", robots=robots)

    @bp.app_context_processor
    def colours() -> dict:
        """Every page's legend entries and dot colours (kb_server.palette)."""
        return {"kinds": palette.kinds(), "palette_css": palette.css()}

    @bp.get("/robots/<name>/corrections")
    def list_corrections(name: str):
        source = store.source(name)
        if source is None:
            return error(404, f"no robot {name!r}" if store.robot(name) is None else
                          f"robot {name!r} was stored before corrections existed: populate it again")
        _, report = review.apply(*source, store.corrections(name))
        return jsonify(report.to_dict())

    @bp.post("/robots/<name>/corrections")
    def add_correction(name: str):
        if not may_write():
            return error(403, "corrections need the server's token (Authorization: Bearer ...)")
        data = request.get_json(silent=True)
        if not isinstance(data, dict):
            return error(400, "send the correction as a JSON object: {action, links, class?, mount?, reviewer?} "
                              "or, for a body part, {part, action, class?, side?, with?, at?, reviewer?}")
        try:
            correction = review.new(data)
            entry = store.add_correction(name, correction)
        except review.CorrectionError as e:
            return error(400, str(e))
        except LookupError as e:
            return error(404 if store.robot(name) is None else 409, e.args[0])
        stored = next(a for a in (entry.corrections or {})["applied"] if a["id"] == correction.id)
        resp = jsonify({"correction": stored, "corrections": entry.corrections})
        resp.status_code = 201
        return resp

    @bp.post("/robots/<name>/populate")
    def repopulate(name: str):
        """Populate a stored robot again from its stored URDF tree (same mode as last time)."""
        if not may_write():
            return error(403, "populating needs the server's token (Authorization: Bearer ...)")
        source = store.source(name)
        if source is None:
            return error(404, f"no stored URDF for robot {name!r}")
        tree, model = source
        return accepted(jobs.submit(tree, name, Settings(structure_only=model.provenance.get("mode") == "structure-only")))

    return bp


def accepted(job) -> Response:
    """202 for a queued populate job, pointing at its status (a full queue raises QueueFull: 429 in the app)."""
    resp = jsonify(job.to_dict())
    resp.status_code = 202
    resp.headers["Location"] = f"/jobs/{job.id}"
    return resp


def robot_page(store: Store, name: str) -> Response | str:
    """The robot's page: SVG tree, components least confident first, review controls."""
    entry = store.robot(name)
    if entry is None:
        return Response(render_template("missing.html", name=name), 404)
    source = store.source(name)
    comps = queries.components(store, name)
    tree = source[0] if source else _tree_from_store(store, name)
    influenced: dict[str, list[dict]] = {}
    corrected_comps = {}
    body: list[dict] = []
    if source:
        corrected, report = review.apply(*source, store.corrections(name))
        body = body_view.rows(tree, corrected, report)
        corrected_comps = {component_iri(entry.ontology_iri, c.name): c for c in corrected.components}
        for corr, comp_name in report.applied:
            if isinstance(corr, review.Correction):
                influenced.setdefault(component_iri(entry.ontology_iri, comp_name), []).append(corr.to_dict())
        stale = [{**c.to_dict(), "reason": why} for c, why in report.stale]
    else:
        stale = []
    rows = []
    for c in comps:
        links = tuple(s["link"] for s in c["subcomponents"] if s.get("link"))
        kind = review.kind_of(c["class"]) or "other"
        model = corrected_comps.get(c["iri"])
        notes = influenced.get(c["iri"], [])
        rows.append({
            **c, "key": c["iri"].rsplit("#", 1)[-1], "kind": kind, "links": links,
            "classes": review.allowed_classes(model) if model else (),
            "mounts": review.mount_options(tree, links) if source and links else (),
            "reviews": notes, "confirmed": any(n["action"] == "confirm" for n in notes),
            "added": any(n["action"] == "add" for n in notes)})
    rows.sort(key=lambda r: (r["confidence"] if r["confidence"] is not None else 1.0, r["key"]))
    outlines = [tree_svg.Outline(r["key"], f"{r['class']} ({r['confidence']:.2f})" if r["confidence"] is not None
                                 else r["class"], palette.kind_colour(r["kind"]), r["links"], r["mount"],
                                 (r["confidence"] or 0) < 0.5 and not r["confirmed"]) for r in rows]
    tax = vocabulary()
    addable = [c for kind in tax.kinds.values() for c in (kind.cls, *tax.subclasses_below(kind.cls))]
    claimed = {link for r in rows for link in r["links"]}
    return render_template("robot.html", entry=entry, rows=rows, svg=tree_svg.render(tree, outlines, body_view.bands(body)),
                           reviewable=source is not None, stale=stale, links=tree.links, claimed=claimed,
                           addable=addable, body=body, body_legend=body_view.legend(body), sides=SIDE_CHOICES)


def _tree_from_store(store: Store, name: str) -> KinematicTree:
    """The tree of a robot stored before its source was kept, read back from its graph."""
    from urdfkb.pipeline.tree import Edge, Origin
    entry = store.robot(name)
    iri = f"<{entry.robot_iri}>"
    links = store.query(f"PREFIX core: <{CORE_IRI}> SELECT ?n WHERE {{ {iri} core:hasLink ?l . "
                        f"?l core:urdfName ?n }}").as_dicts()
    joints = store.query(f"PREFIX core: <{CORE_IRI}> SELECT ?j ?p ?c WHERE {{ {iri} core:hasJoint ?jj . "
                         f"?jj core:urdfName ?j ; core:hasParentLink/core:urdfName ?p ; "
                         f"core:hasChildLink/core:urdfName ?c }}").as_dicts()
    zero = Origin((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    return KinematicTree(name, tuple(sorted(r["n"] for r in links)),
                         tuple(Edge(r["j"], "fixed", r["p"], r["c"], zero) for r in sorted(joints, key=lambda r: r["j"])))


def sparql_page() -> str:
    """The query editor, offering each bundled query with its defaults filled in ($robot left free)."""
    offered = []
    for q in queries.load_queries().values():
        text = q.text
        for p in q.params:
            text = text.replace(f"${p.name}", p.term(p.default).n3() if p.default is not None else f"?{p.name}")
        offered.append({"name": q.name, "title": q.title, "text": text.replace("$robot", "?robot")})
    return render_template("sparql.html", queries=offered)
