"""The HTTP API: SPARQL 1.1 Protocol at /sparql, populate jobs, robots, named HRI queries.

Writes (SPARQL updates, DELETE /robots/<name>, and POST /populate when a token is configured)
need `Authorization: Bearer <token>`; with no token configured, updates and deletes are refused.
"""
from __future__ import annotations

import hmac
from collections.abc import Mapping
from pathlib import Path

import rdflib
from flask import Flask, Response, jsonify, request
from rdflib.namespace import RDF
from werkzeug.exceptions import HTTPException

from kb_server import queries, ui
from kb_server.jobs import JobManager
from kb_server.sparql import QueryError, QueryTimeout, Result, negotiate, offers_for, serialize
from kb_server.store import EXPORT_FORMATS, RobotNameError, Store, check_robot_name
from pipeline.errors import URDFError
from pipeline.runner import Settings
from pipeline.xacro_input import XacroError, load_description, parse_args

SD = rdflib.Namespace("http://www.w3.org/ns/sparql-service-description#")
FORMATS = rdflib.Namespace("http://www.w3.org/ns/formats/")
MAX_WAIT = 600.0


def create_app(store: Store, jobs: JobManager, token: str | None = None, max_body: int = 10_000_000,
               query_timeout: float = 10.0, package_paths: Mapping[str, Path] | None = None) -> Flask:
    """The Flask app over `store`; populate jobs go to `jobs`; bodies over `max_body` bytes get 413.

    Uploaded xacro files may include only from `package_paths` (none: they read no server file)."""
    app = Flask(__name__)
    app.config["MAX_CONTENT_LENGTH"] = max_body

    def authorized() -> bool:
        sent = request.headers.get("Authorization", "")
        return bool(token) and hmac.compare_digest(sent.encode(), f"Bearer {token}".encode())

    def error(status: int, message: str, plain: bool = False) -> Response:
        if plain:
            return Response(message + "\n", status, mimetype="text/plain")
        return Response(jsonify(error=message).get_data(), status, mimetype="application/json")

    def results(result: Result) -> Response:
        media = negotiate(request.headers.get("Accept"), offers_for(result))
        if media is None:
            return error(406, f"cannot answer as {request.headers.get('Accept')}; offered: {', '.join(offers_for(result))}", True)
        charset = "" if media.endswith("+xml") or media == "application/rdf+xml" else "; charset=utf-8"
        return Response(serialize(result, media), 200, content_type=media + charset)

    def run_query(run) -> Response:
        try:
            return results(run())
        except QueryError as e:
            return error(400, str(e), True)
        except QueryTimeout as e:
            return error(503, str(e), True)

    app.register_blueprint(ui.blueprint(store, jobs, lambda: not token or authorized()))

    @app.errorhandler(HTTPException)
    def http_error(e: HTTPException):
        plain = request.path == "/sparql"
        messages = {413: f"request body larger than the {max_body} byte limit"}
        return error(e.code or 500, messages.get(e.code, e.description or e.name), plain)

    # --- SPARQL 1.1 Protocol -------------------------------------------------------------------

    @app.route("/sparql", methods=["GET", "POST"])
    def sparql():
        if request.args.get("default-graph-uri") or request.args.get("named-graph-uri"):
            return error(400, "default-graph-uri/named-graph-uri are not supported: the default graph is the union of all robots", True)
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
            try:
                store.update(update, query_timeout)
            except QueryError as e:
                return error(400, str(e), True)
            except QueryTimeout as e:
                return error(503, str(e), True)
            except Exception as e:  # the update could not be applied; nothing was committed
                return error(400, f"update failed: {e}", True)
            return Response(status=204)
        return run_query(lambda: store.query(query, query_timeout))

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
        for fmt in ("SPARQL_Results_JSON", "SPARQL_Results_XML", "SPARQL_Results_CSV", "SPARQL_Results_TSV",
                    "Turtle", "RDF_XML", "N-Triples"):
            g.add((svc, SD.resultFormat, FORMATS[fmt]))
        dataset, default = rdflib.BNode(), rdflib.BNode()
        g.add((svc, SD.defaultDataset, dataset))
        g.add((dataset, RDF.type, SD.Dataset))
        g.add((dataset, SD.defaultGraph, default))
        g.add((default, RDF.type, SD.Graph))
        for entry in store.robots():
            named = rdflib.BNode()
            g.add((dataset, SD.namedGraph, named))
            g.add((named, RDF.type, SD.NamedGraph))
            g.add((named, SD.name, rdflib.URIRef(entry.ontology_iri)))
        return results(Result("graph", graph=g))

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
            settings = Settings.from_mapping(fields)
        except ValueError as e:
            return error(400, f"bad pipeline settings: {e}")
        try:
            tree = load_description(data, filename=filename, args=parse_args(xacro_args),
                                    packages=package_paths, max_bytes=max_body)
        except XacroError as e:
            return error(400, f"cannot expand the xacro: {e}")
        except URDFError as e:
            return error(400, f"not a valid URDF: {e}")
        try:
            name = check_robot_name(name or tree.robot_name)
        except RobotNameError as e:
            return error(400, f"{e}: pass ?name=...")
        job = jobs.submit(tree, name, settings)
        resp = jsonify(job.to_dict())
        resp.status_code = 202
        resp.headers["Location"] = f"/jobs/{job.id}"
        return resp

    @app.get("/jobs/<job_id>")
    def job_status(job_id: str):
        job = jobs.get(job_id)
        if job is None:
            return error(404, f"no job {job_id!r}")
        if request.args.get("wait") not in (None, "", "0", "false"):
            try:
                timeout = min(float(request.args.get("timeout", MAX_WAIT)), MAX_WAIT)
            except ValueError:
                return error(400, "timeout must be a number of seconds")
            job.wait(timeout)
        return jsonify(job.to_dict())

    # --- robots ----------------------------------------------------------------------------

    @app.get("/robots")
    def robots():
        return jsonify([e.to_dict() for e in store.robots()])

    @app.get("/robots/<spec>")
    def robot(spec: str):
        name, _, ext = spec.partition(".")
        if ext:
            if ext not in EXPORT_FORMATS:
                return error(404, f"no export format .{ext} (use {', '.join('.' + x for x in EXPORT_FORMATS)})")
            data = store.export(name, ext)
            if data is None:
                return error(404, f"no robot {name!r}")
            resp = Response(data, 200, content_type=EXPORT_FORMATS[ext][1])
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
            return run_query(lambda: queries.run_named(store, name, robot_name, args, query_timeout))
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
