"""Populate jobs: POST /populate (a URDF or xacro upload), POST /robots/<name>/populate (a stored robot again)
and GET /jobs/<id> (its state, optionally waited on)."""
from __future__ import annotations

from collections.abc import Callable, Mapping

from flask import Blueprint, Response, jsonify, request

from urdfkb.kb_server.errors import BadRequest, Forbidden, NotFound, TooManyRequests
from urdfkb.kb_server.replies import accepted
from urdfkb.kb_server.services import Services, services
from urdfkb.kb_server.store import check_robot_name
from urdfkb.pipeline.reading import sandbox
from urdfkb.pipeline.errors import URDFError
from urdfkb.pipeline.reading.ingest import load_urdf
from urdfkb.pipeline.runner import Settings
from urdfkb.pipeline.reading.tree import KinematicTree
from urdfkb.pipeline.reading.xacro_input import XacroError, is_xacro, load_description, parse_args, refuse_args
from urdfkb.settings import JOB_WAIT, WAIT_RETRY_AFTER

bp = Blueprint("jobs", __name__)


@bp.post("/populate")
def populate() -> Response:
    kb = services()
    if not kb.may_write():
        raise Forbidden("populating needs the server's token (Authorization: Bearer ...)")
    if request.mimetype == "multipart/form-data":
        upload = request.files.get("urdf") or next(iter(request.files.values()), None)
        if upload is None:
            raise BadRequest("multipart request without a file (send the URDF as field 'urdf')")
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
        raise BadRequest("empty body: send the URDF as the raw body or as multipart field 'urdf'")
    settings = kb.policy.check_settings(Settings.from_mapping(fields))
    if name is not None:
        name = check_robot_name(name)
    args = parse_args(xacro_args)
    if is_xacro(filename, data):
        return accepted(kb.jobs.submit(_xacro_loader(kb, data, filename, args), name, settings))
    refuse_args(filename, args)
    return accepted(kb.jobs.submit(_urdf_loader(kb, data), name, settings))


@bp.post("/robots/<name>/populate")
def repopulate(name: str) -> Response:
    """Populate a stored robot again from its stored URDF tree (same mode as last time)."""
    kb = services()
    if not kb.may_write():
        raise Forbidden("populating needs the server's token (Authorization: Bearer ...)")
    tree, model = kb.store.source(name)
    return accepted(kb.jobs.submit(tree, name, Settings(structure_only=model.provenance.get("mode") == "structure-only")))


def _urdf_loader(kb: Services, data: bytes) -> Callable[[], KinematicTree]:
    """The job's first step for a URDF upload: parsing and checking it, off the request thread (a large
    hostile document costs a job slot, never a server thread or the store lock)."""
    max_body, max_links = kb.max_body, kb.max_links

    def load() -> KinematicTree:
        try:
            return load_urdf(data, max_bytes=max_body, max_links=max_links)
        except URDFError as e:
            raise URDFError(f"not a valid URDF: {e}") from None
    return load


def _xacro_loader(kb: Services, data: bytes, filename: str | None,
                  args: Mapping[str, str]) -> Callable[[], KinematicTree]:
    """The job's first step for a xacro upload: expansion, confined by pipeline.reading.sandbox unless the
    operator trusts xacro. Refused at once (sandbox.Unavailable: 403) where the machine offers no sandbox."""
    confined = not kb.trust_xacro
    if confined and (reason := sandbox.unavailable()):
        raise sandbox.Unavailable(f"xacro input is disabled on this server: xacro expressions are Python code, and "
                                  f"this machine cannot run them confined ({reason}); send the expanded URDF, or the "
                                  "operator can start the server with --trust-xacro")
    packages, max_body, max_links, timeout = kb.package_paths, kb.max_body, kb.max_links, kb.xacro_timeout

    def load() -> KinematicTree:
        try:
            return load_description(data, filename=filename, args=args, packages=packages,
                                    max_bytes=max_body, max_links=max_links, timeout=timeout, confined=confined)
        except XacroError as e:
            raise XacroError(f"cannot expand the xacro: {e}") from None
    return load


@bp.get("/jobs/<job_id>")
def job_status(job_id: str) -> Response:
    kb = services()
    job = kb.jobs.get(job_id)
    if job is None:
        raise NotFound(f"no job {job_id[:64]!r}: {kb.jobs.retention}")
    if request.args.get("wait") not in (None, "", "0", "false"):
        timeout = request.args.get("timeout", -1.0, type=float) if "timeout" in request.args else JOB_WAIT  # -1: NaN
        if not 0 <= timeout:  # also NaN
            raise BadRequest(f"timeout must be a number of seconds (at most {JOB_WAIT:g} are waited)")
        timeout = min(timeout, JOB_WAIT)
        if not kb.waiters.acquire(blocking=False):
            raise TooManyRequests(f"{kb.max_waiters} clients are already waiting on jobs: poll without wait=1, "
                                  "or retry", WAIT_RETRY_AFTER)
        try:
            job.wait(timeout)
        finally:
            kb.waiters.release()
    return jsonify(job.to_dict())
