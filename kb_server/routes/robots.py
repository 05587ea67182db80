"""Stored robots: GET /robots, GET /robots/<name> (JSON, or the robot page for browsers), GET
/robots/<name>.<ext> (a self-contained export) and DELETE /robots/<name> (with the token)."""
from __future__ import annotations

from flask import Blueprint, Response, jsonify

from urdfkb.kb_server import queries, ui
from urdfkb.kb_server.errors import Forbidden, NotFound
from urdfkb.kb_server.services import services
from urdfkb.kb_server.store import UnknownRobot
from urdfkb.pipeline.knowledge.formats import BY_EXTENSION

bp = Blueprint("robots", __name__)


@bp.get("/robots")
def robots() -> Response:
    return jsonify([e.to_dict() for e in services().store.robots()])


@bp.get("/robots/<spec>")
def robot(spec: str) -> Response | str:
    store = services().store
    name, _, ext = spec.partition(".")
    if ext:
        if ext not in BY_EXTENSION:
            raise NotFound(f"no export format .{ext} (use {', '.join('.' + x for x in BY_EXTENSION)})")
        data = store.export(name, ext)
        if data is None:
            raise UnknownRobot(name)
        resp = Response(data, 200, content_type=BY_EXTENSION[ext].media_type)
        resp.headers["Content-Disposition"] = f'attachment; filename="{name}.{ext}"'
        return resp
    if ui.wants_html():
        return ui.robot_page(store, name)
    entry = store.require(name)
    return jsonify({**entry.to_dict(), "components": queries.components(store, name)})


@bp.delete("/robots/<name>")
def delete_robot(name: str) -> Response:
    kb = services()
    if not kb.authorized():
        raise Forbidden("deleting a robot needs the server's token (Authorization: Bearer ...)")
    entry, mirror_error = kb.jobs.delete_robot(name)
    if entry is None:
        raise UnknownRobot(name)
    return jsonify({"deleted": name, "ontology": entry.ontology_iri, "mirror_error": mirror_error})
