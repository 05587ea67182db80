"""Reviewers' corrections of a stored robot: GET /robots/<name>/corrections (what applies, what went
stale) and POST /robots/<name>/corrections (one more, with the token where one is configured)."""
from __future__ import annotations

from flask import Blueprint, Response, jsonify

from urdfkb.kb_server import corrections as review
from urdfkb.kb_server.errors import Forbidden
from urdfkb.kb_server.json_body import json_object
from urdfkb.kb_server.services import services

bp = Blueprint("corrections", __name__)
USAGE = ("send the correction as a JSON object: {action, links, class?, mount?, reviewer?} "
         "or, for a body part, {part, action, class?, side?, with?, at?, reviewer?}")


@bp.get("/robots/<name>/corrections")
def list_corrections(name: str) -> Response:
    return jsonify(services().store.reviewed(name).report.to_dict())


@bp.post("/robots/<name>/corrections")
def add_correction(name: str) -> Response:
    kb = services()
    if not kb.may_write():
        raise Forbidden("corrections need the server's token (Authorization: Bearer ...)")
    correction = review.new(json_object(USAGE))
    entry = kb.store.add_correction(name, correction)
    stored = next(a for a in entry.corrections["applied"] if a["id"] == correction.id)
    resp = jsonify({"correction": stored, "corrections": entry.corrections})
    resp.status_code = 201
    return resp
