"""A question in words: GET /ask?robot=NAME&q=QUESTION, answered by one bundled query the embedded model
chooses (kb_server.ask), or refused."""
from __future__ import annotations

import threading

from flask import Blueprint, Response, current_app, jsonify, request

from urdfkb.kb_server.ask import Asker
from urdfkb.kb_server.errors import BadRequest, ServiceUnavailable
from urdfkb.kb_server.jobs import ModelWorker
from urdfkb.kb_server.services import services

bp = Blueprint("ask", __name__)
EXTENSION = "urdfkb.ask"  # an Asker given to create_app, or made at the first question
_making = threading.Lock()


def asker() -> Asker:
    """The app's Asker: the one it was made with, else one on the jobs' model thread (the warm default model)."""
    with _making:
        if current_app.extensions.get(EXTENSION) is None:
            runner = services().jobs.runner
            if not isinstance(runner, ModelWorker):
                raise ServiceUnavailable("this server has no embedded model to read questions with")
            current_app.extensions[EXTENSION] = Asker(runner.use)
        return current_app.extensions[EXTENSION]


@bp.get("/ask")
def ask() -> Response:
    robot, question = request.args.get("robot"), request.args.get("q")
    if not robot or question is None:
        raise BadRequest("give the robot and the question: /ask?robot=NAME&q=QUESTION")
    return jsonify(asker().ask(services().store, robot, question))
