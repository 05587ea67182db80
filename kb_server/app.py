"""The HTTP API: SPARQL 1.1 Protocol at /sparql, populate jobs, robots, named HRI queries.

Writes (SPARQL updates, DELETE /robots/<name>, and POST /populate when a token is configured)
need `Authorization: Bearer <token>`; with no token configured, updates and deletes are refused.
Every request first passes the checks of kb_server.security (Host, cross-site writes).
"""
from __future__ import annotations

import hmac
import threading
from collections.abc import Callable, Mapping
from pathlib import Path

import rdflib
from flask import Flask, Response, jsonify, request
from rdflib.namespace import RDF
from werkzeug.exceptions import HTTPException

from urdfkb.kb_server import queries, ui
from urdfkb.kb_server.index import WorkerCrashed
from urdfkb.kb_server.jobs import JobManager, QueueFull
from urdfkb.kb_server.results import ResultTooLarge
from urdfkb.kb_server.security import Policy, Refused
from urdfkb.kb_server.sparql import NotAcceptable, QueryError, QueryTimeout, Result, negotiate
from urdfkb.kb_server.store import ReadOnlyGraph, RobotNameError, Store, check_robot_name
from urdfkb.limits import JOB_WAIT, MAX_BYTES, MAX_LINKS, QUERY_TIMEOUT, THREADS, job_waiters
from urdfkb.pipeline import sandbox
from urdfkb.pipeline.errors import URDFError
from urdfkb.pipeline.formats import BY_EXTENSION, GRAPH_FORMATS, GRAPH_MEDIA, RESULTS_FORMATS
from urdfkb.pipeline.namespaces import CORE_GRAPH
from urdfkb.pipeline.runner import Settings
from urdfkb.pipeline.tree import KinematicTree
from urdfkb.pipeline.xacro_input import XacroError, is_xacro, load_description, parse_args

SD = rdflib.Namespace("http://www.w3.org/ns/sparql-service-description#")


def create_app(store: Store, jobs: JobManager, token: str | None = None, max_body: int = MAX_BYTES,
               query_timeout: float = QUERY_TIMEOUT, policy: Policy | None = None, max_links: int = MAX_LINKS,
               max_waiters: int = job_waiters(THREADS), package_paths: Mapping[str, Path] | None = None,
               trust_xacro: bool = False) -> Flask:
    """The Flask app over `store`; populate jobs go to `jobs`; bodies over `max_body` bytes get 413.

    `policy` (default: a loopback server with nothing opened) checks every request; at most
    `max_waiters` clients wait on a job at once (GET /jobs/<id>?wait=1), so waits never hold
    every server thread. Uploaded xacro files may include only from `package_paths` (none: they
    read no server file), inside the sandbox of pipeline.sandbox unless `trust_xacro`; expansion
    is the job's first step, never the request's."""
    app = Flask(__name__)
    app.config["MAX_CONTENT_LENGTH"] = max_body
    policy = policy or Policy()
    waiters = threading.BoundedSemaphore(max_waiters)

    def authorized() -> bool:
        sent = request.headers.get("Authorization", "")
        return bool(token) and hmac.compare_digest(sent.encode(), f"Bearer {token}".encode())

    def error(status: int, message: str, plain: bool = False) -> Response:
        """A refusal as JSON, or as text for /sparql; a lone surrogate in `message` is escaped, never a 500."""
        if plain:
            return Response((message + "\n").encode("utf-8", "backslashreplace"), status, mimetype="text/plain")
        return Response(jsonify(error=message).get_data(), status, mimetype="application/json")

    policy.install(app, lambda status, message: error(status, message, request.path == "/sparql"))

    def results(result: Result) -> Response:
        charset = "" if result.media_type.endswith("xml") else "; charset=utf-8"
        return Response(result.body, 200, content_type=result.media_type + charset)

    def answer(run) -> Response:
        """`run()`'s response, or the SPARQL error it raised as a plain-text status."""
        try:
            return run()
        except QueryError as e:
            return error(400, str(e), True)
        except ReadOnlyGraph as e:
            return error(403, str(e), True)
        except NotAcceptable as e:
            return error(406, str(e), True)
        except ResultTooLarge as e:
            return error(413, str(e), True)
        except QueryTimeout as e:
            return error(503, str(e), True)
        except WorkerCrashed as e:
            return error(500, str(e), True)

    app.register_blueprint(ui.blueprint(store, jobs, lambda: not token or authorized(), error))

    @app.errorhandler(QueueFull)
    def queue_full(e: QueueFull):
        """Any route that submits a job: 429 with Retry-After while the queue is full."""
        resp = error(429, str(e))
        resp.headers["Retry-After"] = str(e.retry_after)
        return resp

    @app.errorhandler(HTTPException)
    def http_error(e: HTTPException):
        plain = request.path == "/sparql"
        messages = {413: f"request body larger than the {max_body} byte limit"}
        return error(e.code or 500, messages.get(e.code, e.description or e.name), plain)

    # --- SPARQL 1.1 Protocol -------------------------------------------------------------------

    @app.route("/sparql", methods=["GET", "POST"])
    def sparql():
        query, update = _protocol_operation()
        if query is None and update is None:
            if request.method == "GET" and ui.wants_html():
                return ui.sparql_page()
            if request.method == "GET":
                return service_description()
            return error(415 if request.mimetype not in _FORM_TYPES else 400,
                         "POST a query (application/sparql-query or form field query) or an update "
                         "(application/sparql-update or form field update)", True)
        if query is not None and update is not None:
            return error(400, "give a query or an update, not both", True)
        if update is not None:
            if request.method != "POST":
                return error(400, "updates must be sent by POST", True)
            if not authorized():
                return error(403, "SPARQL updates need the server's token (Authorization: Bearer ...)", True)

            def apply() -> Response:
                store.update(update, query_timeout)
                return Response(status=204)

            return answer(apply)
        dataset = request.values if request.mimetype in _FORM_TYPES else request.args
        default, named = dataset.getlist("default-graph-uri"), dataset.getlist("named-graph-uri")
        given = bool(default or named)  # the protocol's dataset, instead of the union default graph
        return answer(lambda: results(store.query(query, query_timeout, request.headers.get("Accept"),
                                                  default if given else None, named if given else None)))

    def service_description() -> Response:
        g = rdflib.Graph()
        g.bind("sd", SD)
        svc = rdflib.BNode()
        g.add((svc, RDF.type, SD.Service))
        g.add((svc, SD.endpoint, rdflib.URIRef(request.base_url)))
        g.add((svc, SD.supportedLanguage, SD.SPARQL11Query))
        if token:
            g.add((svc, SD.supportedLanguage, SD.SPARQL11Update))
        g.add((svc, SD.feature, SD.UnionDefaultGraph))
        for fmt in (*RESULTS_FORMATS, *GRAPH_FORMATS):
            g.add((svc, SD.resultFormat, rdflib.URIRef(fmt.oxigraph.iri)))
        dataset, default = rdflib.BNode(), rdflib.BNode()
        g.add((svc, SD.defaultDataset, dataset))
        g.add((dataset, RDF.type, SD.Dataset))
        g.add((dataset, SD.defaultGraph, default))
        g.add((default, RDF.type, SD.Graph))
        for iri in [CORE_GRAPH] + [entry.ontology_iri for entry in store.robots()]:
            named = rdflib.BNode()
            g.add((dataset, SD.namedGraph, named))
            g.add((named, RDF.type, SD.NamedGraph))
            g.add((named, SD.name, rdflib.URIRef(iri)))
        media = negotiate(request.headers.get("Accept"), list(GRAPH_MEDIA))
        if media is None:
            return error(406, f"cannot answer as {request.headers.get('Accept')}; offered: {', '.join(GRAPH_MEDIA)}", True)
        body = g.serialize(format=GRAPH_MEDIA[media].rdflib, encoding="utf-8")
        return Response(body, 200, content_type=media + ("" if media.endswith("xml") else "; charset=utf-8"))

    # --- populate and jobs ---------------------------------------------------------------------

    @app.post("/populate")
    def populate():
        if token and not authorized():
            return error(403, "populating needs the server's token (Authorization: Bearer ...)")
        if request.mimetype == "multipart/form-data":
            upload = request.files.get("urdf") or next(iter(request.files.values()), None)
            if upload is None:
                return error(400, "multipart request without a file (send the URDF as field 'urdf')")
            data, fields, filename = upload.read(), request.form.to_dict(), upload.filename
        else:
            data, fields, filename = request.get_data(), {}, None
        xacro_args = request.args.getlist("xacro_arg") + request.form.getlist("xacro_arg")
        fields = {**request.args.to_dict(), **fields}
        fields.pop("xacro_arg", None)
        xacro_args += fields.pop("xacro_args", "").split()
        name = fields.pop("name", None)
        filename = fields.pop("filename", None) or filename  # for a raw body: e.g. ?filename=arm.urdf.xacro
        if not data:
            return error(400, "empty body: send the URDF as the raw body or as multipart field 'urdf'")
        try:
            settings = policy.check_settings(Settings.from_mapping(fields))
        except ValueError as e:
            return error(400, f"bad pipeline settings: {e}")
        except Refused as e:
            return error(e.status, str(e))
        try:
            if name is not None:
                name = check_robot_name(name)
            args = parse_args(xacro_args)
            if is_xacro(filename, data):
                return ui.accepted(jobs.submit(xacro_loader(data, filename, args), name, settings))
            tree = load_description(data, filename=filename, args=args, max_bytes=max_body, max_links=max_links)
            return ui.accepted(jobs.submit(tree, check_robot_name(name or tree.robot_name), settings))
        except XacroError as e:
            return error(400, f"cannot expand the xacro: {e}")
        except URDFError as e:
            return error(400, f"not a valid URDF: {e}")
        except RobotNameError as e:
            return error(400, f"{e}: pass ?name=...")
        except Refused as e:
            return error(e.status, str(e))

    def xacro_loader(data: bytes, filename: str | None, args: Mapping[str, str]) -> Callable[[], KinematicTree]:
        """The job's first step for a xacro upload: expansion, confined by pipeline.sandbox unless the
        operator trusts xacro. Refused at once (403) where the machine offers no sandbox."""
        confined = not trust_xacro
        if confined and (reason := sandbox.unavailable()):
            raise Refused(403, f"xacro input is disabled on this server: xacro expressions are Python code, and "
                             f"this machine cannot run them confined ({reason}); send the expanded URDF, or the "
                             "operator can start the server with --trust-xacro")

        def load() -> KinematicTree:
            try:
                return load_description(data, filename=filename, args=args, packages=package_paths,
                                        max_bytes=max_body, max_links=max_links, confined=confined)
            except XacroError as e:
                raise XacroError(f"cannot expand the xacro: {e}") from None
        return load

    @app.get("/jobs/<job_id>")
    def job_status(job_id: str):
        job = jobs.get(job_id)
        if job is None:
            return error(404, f"no job {job_id[:64]!r}: {jobs.retention}")
        if request.args.get("wait") not in (None, "", "0", "false"):
            try:
                timeout = float(request.args.get("timeout", JOB_WAIT))
            except ValueError:
                timeout = -1.0
            if not 0 <= timeout:  # also NaN
                return error(400, f"timeout must be a number of seconds (at most {JOB_WAIT:g} are waited)")
            timeout = min(timeout, JOB_WAIT)
            if not waiters.acquire(blocking=False):
                resp = error(429, f"{max_waiters} clients are already waiting on jobs: poll without wait=1, or retry")
                resp.headers["Retry-After"] = "1"
                return resp
            try:
                job.wait(timeout)
            finally:
                waiters.release()
        return jsonify(job.to_dict())

    # --- robots ----------------------------------------------------------------------------

    @app.get("/robots")
    def robots():
        return jsonify([e.to_dict() for e in store.robots()])

    @app.get("/robots/<spec>")
    def robot(spec: str):
        name, _, ext = spec.partition(".")
        if ext:
            if ext not in BY_EXTENSION:
                return error(404, f"no export format .{ext} (use {', '.join('.' + x for x in BY_EXTENSION)})")
            data = store.export(name, ext)
            if data is None:
                return error(404, f"no robot {name!r}")
            resp = Response(data, 200, content_type=BY_EXTENSION[ext].media_type)
            resp.headers["Content-Disposition"] = f'attachment; filename="{name}.{ext}"'
            return resp
        if ui.wants_html():
            return ui.robot_page(store, name)
        entry = store.robot(name)
        if entry is None:
            return error(404, f"no robot {name!r}")
        return jsonify({**entry.to_dict(), "components": queries.components(store, name)})

    @app.delete("/robots/<name>")
    def delete_robot(name: str):
        if not authorized():
            return error(403, "deleting a robot needs the server's token (Authorization: Bearer ...)")
        entry, mirror_error = jobs.delete_robot(name)
        if entry is None:
            return error(404, f"no robot {name!r}")
        return jsonify({"deleted": name, "ontology": entry.ontology_iri, "mirror_error": mirror_error})

    # --- named HRI queries -----------------------------------------------------------------

    @app.get("/queries")
    def list_queries():
        return jsonify([q.describe() for q in queries.load_queries().values()])

    @app.get("/queries/<name>")
    def named_query(name: str):
        args = request.args.to_dict()
        robot_name = args.pop("robot", None)
        if not robot_name:
            return error(400, "give the robot: ?robot=NAME")
        try:
            return answer(lambda: results(queries.run_named(store, name, robot_name, args, query_timeout,
                                                            request.headers.get("Accept"))))
        except (queries.UnknownQuery, queries.UnknownRobot) as e:
            return error(404, e.args[0])
        except queries.ParamError as e:
            return error(400, str(e))

    return app


_FORM_TYPES = ("application/x-www-form-urlencoded", "multipart/form-data")


def _protocol_operation() -> tuple[str | None, str | None]:
    """(query, update) text from a SPARQL 1.1 Protocol request (GET args, form, or direct POST)."""
    if request.method == "GET":
        return request.args.get("query"), request.args.get("update")
    if request.mimetype == "application/sparql-query":
        return request.get_data(as_text=True), None
    if request.mimetype == "application/sparql-update":
        return None, request.get_data(as_text=True)
    if request.mimetype in _FORM_TYPES:
        return request.form.get("query"), request.form.get("update")
    return None, None
