"""The bundled HRI queries: GET /queries (their names, titles and parameters) and GET /queries/<name>?robot=...
(one answered for one robot, bounded as /sparql answers are)."""
from __future__ import annotations

from flask import Blueprint, Response, jsonify, request

from urdfkb.kb_server import queries
from urdfkb.kb_server.errors import BadRequest
from urdfkb.kb_server.replies import results
from urdfkb.kb_server.services import services

bp = Blueprint("queries", __name__)


@bp.get("/queries")
def list_queries() -> Response:
    return jsonify([q.describe() for q in queries.load_queries().values()])


@bp.get("/queries/<name>")
def named_query(name: str) -> Response:
    kb = services()
    args = request.args.to_dict()
    robot_name = args.pop("robot", None)
    if not robot_name:
        raise BadRequest("give the robot: ?robot=NAME")
    return results(queries.run_named(kb.store, name, robot_name, args, kb.query_timeout, request.headers.get("Accept")))
