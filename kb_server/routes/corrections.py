"""Reviewers' corrections of a stored robot: GET /robots/<name>/corrections (what applies, what went
stale) and POST /robots/<name>/corrections (one more, with the token where one is configured)."""
from __future__ import annotations

from flask import Blueprint, jsonify

from urdfkb.kb_server import corrections as review
from urdfkb.kb_server.json_body import BadJSON, json_body
from urdfkb.kb_server.replies import error
from urdfkb.kb_server.services import services

bp = Blueprint("corrections", __name__)
USAGE = ("send the correction as a JSON object: {action, links, class?, mount?, reviewer?} "
         "or, for a body part, {part, action, class?, side?, with?, at?, reviewer?}")


@bp.get("/robots/<name>/corrections")
def list_corrections(name: str):
    store = services().store
    source = store.source(name)
    if source is None:
        return error(404, f"no robot {name!r}" if store.robot(name) is None else
                      f"robot {name!r} was stored before corrections existed: populate it again")
    _, report = review.apply(*source, store.corrections(name))
    return jsonify(report.to_dict())


@bp.post("/robots/<name>/corrections")
def add_correction(name: str):
    kb = services()
    if not kb.may_write():
        return error(403, "corrections need the server's token (Authorization: Bearer ...)")
    try:
        data = json_body()
    except BadJSON as e:
        return error(e.status, f"{e}: {USAGE}")
    if not isinstance(data, dict):
        return error(400, USAGE)
    try:
        correction = review.new(data)
        entry = kb.store.add_correction(name, correction)
    except review.CorrectionError as e:
        return error(400, str(e))
    except LookupError as e:
        return error(404 if kb.store.robot(name) is None else 409, e.args[0])
    stored = next(a for a in (entry.corrections or {})["applied"] if a["id"] == correction.id)
    resp = jsonify({"correction": stored, "corrections": entry.corrections})
    resp.status_code = 201
    return resp
