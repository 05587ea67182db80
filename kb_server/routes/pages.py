"""The index page (GET /: the stored robots, an upload form) and what every page's template gets (colours,
the review threshold)."""
from __future__ import annotations

from collections import Counter

from flask import Blueprint, render_template

from urdfkb.kb_server import corrections as review
from urdfkb.kb_server import palette, queries
from urdfkb.kb_server.services import services
from urdfkb.settings import REVIEW_THRESHOLD

bp = Blueprint("pages", __name__)


@bp.get("/")
def index() -> str:
    store = services().store
    robots = []
    for entry in store.robots():
        comps = queries.components(store, entry.name)
        low = queries.run_named(store, "low_confidence", entry.name, {})
        kinds = Counter(review.kind_of(c["class"]) or "other" for c in comps)
        robots.append({"name": entry.name, "updated": entry.updated, "kinds": kinds, "low": len(low.bindings())})
    return render_template("index.html", robots=robots)


@bp.app_context_processor
def page_context() -> dict:
    """Every page's legend entries and dot colours (kb_server.palette), and the review threshold."""
    return {"kinds": palette.kinds(), "palette_css": palette.css(), "review_threshold": REVIEW_THRESHOLD}
