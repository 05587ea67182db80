"""A small client for dialogue code: the bundled HRI queries of a running `urdfkb serve`, as Python objects.

    from urdfkb.client import KnowledgeBase

    kb = KnowledgeBase("http://127.0.0.1:8000")            # token="..." where the server wants one
    for joint in kb.body_part_joints("pr2", "arm", side="left"):
        print(joint.name, joint.lower, joint.upper)        # floats (rad or m), None where the URDF gives none

One method per bundled query (`GET /queries/<name>?robot=...`), each returning a list of frozen
dataclasses with Python values: names as plain strings (the URDF's or the pipeline's, percent-escapes
undone), classes as ontology local names (`"RGBDCamera"`), numbers as floats. `query()` runs any
query by name and gives its rows as dicts of strings. Standard library only (urllib); one HTTP
request per call, so an instance may be shared between threads. It follows no redirect: a redirect
could lead anywhere, and the request would take the token there; a 3xx answer raises `QueryFailed`
naming its `Location` (give the client the URL it points to, if it is the server's).

`populate()` sends a URDF or xacro document (POST /populate) and `job()` follows the job it starts; a
document over the server's body limit (which every answer of the server states) is refused here, unsent.

Errors: `ServerUnavailable` when nothing answers at the URL (or not in time), `UnknownRobot` when the
server has no robot of that name, `QueryFailed` for any other refusal (a bad parameter, a query the
server does not have, a timeout on the server, a missing token), `TooLarge` for a document over the
server's limit. All four are `ClientError`s.
"""
from __future__ import annotations

import http.client
import json
import os
import re
import urllib.error
import urllib.parse
import urllib.request
from dataclasses import dataclass

from urdfkb import __version__, local_name
from urdfkb.settings import ASK_TIMEOUT, CLIENT_TIMEOUT

__all__ = [
    "KnowledgeBase", "ClientError", "ServerUnavailable", "UnknownRobot", "QueryFailed", "TooLarge",
    "CameraLink", "Sensor", "MountedComponent", "EndEffector", "ReviewItem", "SubPart", "Component",
    "BodyPart", "Joint", "LocatedComponent", "ArmEndEffector", "CameraFrame", "ArmReach", "GripperOpening", "Reply", "class_words",
]

SIDES = ("left", "right")
MAX_BODY_HEADER = "Urdfkb-Max-Body"  # where the server states its limit on request bodies (kb_server.http_bodies)


class ClientError(Exception):
    """Anything the knowledge-base server did not answer as asked."""


class ServerUnavailable(ClientError):
    """Nothing answered at the server's URL (refused, unreachable, cut off or too slow)."""

    def __init__(self, url: str, reason: str):
        super().__init__(f"urdfkb server at {url} is unavailable: {reason}")
        self.url, self.reason = url, reason


class UnknownRobot(ClientError, LookupError):
    """The server holds no robot of that name."""

    def __init__(self, robot: str, url: str):
        super().__init__(f"no robot {robot!r} on the urdfkb server at {url}")
        self.robot, self.url = robot, url


class QueryFailed(ClientError):
    """The server refused or failed the request (`query`: the bundled query's name, or "populate", "job"):
    `status` is the HTTP status, `message` its reason."""

    def __init__(self, query: str, status: int, message: str, url: str):
        super().__init__(f"query {query!r} failed on the urdfkb server at {url}: HTTP {status}: {message}")
        self.query, self.status, self.message, self.url = query, status, message, url


class TooLarge(ClientError, ValueError):
    """A document larger than the server accepts, refused before it was sent: `size` and `limit` in bytes."""

    def __init__(self, what: str, size: int, limit: int, url: str):
        super().__init__(f"{what} is {size:,} bytes, over the {limit:,}-byte limit of the urdfkb server at {url} "
                         "on request bodies: not sent")
        self.size, self.limit, self.url = size, limit, url


# --- answers ---------------------------------------------------------------------------------------

@dataclass(frozen=True)
class CameraLink:
    """A URDF link that belongs to a camera (`cameras`)."""
    link: str
    camera: str                       # the camera component's name
    cls: str                          # its class, e.g. "RGBDCamera"


@dataclass(frozen=True)
class Sensor:
    """A sensor with its class and mount (`sensors`)."""
    name: str
    cls: str
    mount: str | None
    confidence: float | None


@dataclass(frozen=True)
class MountedComponent:
    """A component mounted on or below a link (`mounted_below`)."""
    name: str
    cls: str
    mount: str


@dataclass(frozen=True)
class EndEffector:
    """An end-effector (`end_effectors`, `arm_end_effector`); `label` and `joints` come with the latter."""
    name: str
    cls: str
    mount: str | None
    tcp: str | None                   # the tool centre point's link
    contacts: tuple[str, ...]         # contact surface links
    label: str | None = None          # the class's English label, e.g. "parallel gripper"
    joints: tuple[str, ...] = ()      # its own (finger) joints


@dataclass(frozen=True)
class ReviewItem:
    """A component or sub-component classified with low confidence (`low_confidence`)."""
    component: str                    # the component's name (the owner's, for a sub-component)
    cls: str
    confidence: float
    link: str                         # its mount (component) or its own link (sub-component)
    subpart: bool


@dataclass(frozen=True)
class SubPart:
    cls: str
    link: str | None
    confidence: float | None


@dataclass(frozen=True)
class Component:
    """A component (a sensor or end-effector) with its sub-components (`components`)."""
    name: str
    cls: str
    confidence: float | None
    mount: str | None
    subparts: tuple[SubPart, ...]


@dataclass(frozen=True)
class BodyPart:
    """A part of the robot's body (`body_parts`), its movable joints root-most first."""
    name: str
    cls: str                          # Arm, Leg, Head, Torso, Wheel, MobileBase (or a subclass)
    label: str | None                 # the class's English label, e.g. "mobile base"
    side: str | None                  # "left", "right" or None
    parent: str | None                # the part it belongs to (a wheel's base), None: the robot
    mount: str | None                 # the link it hangs from
    confidence: float | None
    joints: tuple[str, ...]


@dataclass(frozen=True)
class Joint:
    """A movable joint of a body part with its limits and axis (`body_part_joints`)."""
    name: str
    type: str | None                  # "revolute", "continuous", "prismatic", ...
    lower: float | None               # position limits (rad or m), None where the URDF gives none
    upper: float | None
    velocity: float | None            # rad/s or m/s
    effort: float | None              # N m or N
    axis: tuple[float, float, float] | None   # in the joint frame
    part: str                         # the body part's name
    side: str | None


@dataclass(frozen=True)
class LocatedComponent:
    """A sensor or end-effector located on a body part (`located_on`)."""
    name: str
    cls: str
    label: str | None
    mount: str | None
    part: str                         # the body part's name
    side: str | None                  # the body part's side


@dataclass(frozen=True)
class ArmEndEffector:
    """An arm and the end-effector at its end (`arm_end_effector`); `end_effector` None: the arm carries none."""
    arm: str
    side: str | None
    end_effector: EndEffector | None


@dataclass(frozen=True)
class CameraFrame:
    """An optical frame of a camera, with what the camera's simulator declaration states (`camera_frames`)."""
    camera: str                       # the camera component's name
    cls: str                          # its class, e.g. "RGBDCamera"
    frame: str                        # the optical frame's link
    modality: str                     # the frame's class: "RgbFrame", "DepthFrame", "InfraredFrame" or "OpticalFrame"
    modality_label: str | None        # its English label, e.g. "depth frame"
    fov: float | None                 # the camera's horizontal field of view, rad
    width: int | None                 # its image size, px
    height: int | None
    rate: float | None                # its update rate, Hz
    reference_frames: tuple[str, ...]  # the links its measurements are expressed in


@dataclass(frozen=True)
class ArmReach:
    """An arm's degrees of freedom and reach (`arm_reach`)."""
    arm: str
    side: str | None
    mount: str | None                 # the link it hangs from
    degrees_of_freedom: int | None    # joints that move on their own
    reach: float | None               # m, from where its first joint sits to its tool centre point


@dataclass(frozen=True)
class GripperOpening:
    """A gripper's maximum opening (`gripper_opening`)."""
    gripper: str
    cls: str                          # e.g. "ParallelGripper"
    label: str | None                 # the class's English label
    mount: str | None
    arm: str | None                   # the arm it is located on
    side: str | None                  # that arm's side
    opening: float | None             # m, how far its opposing fingertips move apart


# --- the client ------------------------------------------------------------------------------------

@dataclass(frozen=True)
class Reply:
    """The answer to a question in words: the query chosen (None when refused), its parameters, its rows (JSON
    values: numbers as numbers), one sentence made from them by code, the choice's probability, and whether
    the question was refused (outside what the robot knows about its body, or not understood)."""
    query: str | None
    params: dict
    rows: list[dict]
    answer: str
    confidence: float
    refused: bool


class _NoRedirect(urllib.request.HTTPRedirectHandler):
    """Refuses every redirect: urllib then raises the 3xx answer as an HTTPError."""

    def redirect_request(self, req, fp, code, msg, headers, newurl):
        return None


_OPENER = urllib.request.build_opener(_NoRedirect)


class KnowledgeBase:
    """The bundled HRI queries and the populate jobs of the urdfkb server at `url` (e.g. "http://127.0.0.1:8000").

    `token` is sent as `Authorization: Bearer <token>` (a server or proxy that wants one), to `url` only:
    a redirect is never followed (QueryFailed names where it pointed); `timeout` bounds each request in
    seconds."""

    def __init__(self, url: str, token: str | None = None, timeout: float = CLIENT_TIMEOUT):
        parts = urllib.parse.urlsplit(url)
        if parts.scheme not in ("http", "https") or not parts.netloc:
            raise ValueError(f"not an http(s) URL: {url!r}")
        self.url = url.rstrip("/")
        self.token = token
        self.timeout = timeout

    def __repr__(self) -> str:
        return f"KnowledgeBase({self.url!r})"

    # --- generic ---------------------------------------------------------------------------------

    def robots(self) -> list[str]:
        """The names of the robots the server holds."""
        return [entry["name"] for entry in self._get("/robots", "robots")]

    def query(self, name: str, robot: str, **params: str | float | int | None) -> list[dict[str, str]]:
        """Bundled query `name` for `robot`: one dict per row, variable -> value as text (unbound: absent).
        A parameter given as None is left out (the query's default applies)."""
        if not robot:
            raise ValueError("give the robot's name")
        args = {"robot": robot, **{k: str(v) for k, v in params.items() if v is not None}}
        path = f"/queries/{urllib.parse.quote(name, safe='')}?{urllib.parse.urlencode(args)}"
        answer = self._get(path, name, robot)
        try:
            return [{var: cell["value"] for var, cell in row.items()} for row in answer["results"]["bindings"]]
        except (KeyError, TypeError) as e:
            raise QueryFailed(name, 200, f"the answer is not SPARQL JSON results ({e!r})", self.url) from None

    def ask(self, robot: str, question: str, timeout: float | None = None) -> Reply:
        """A question in words (`GET /ask`): the bundled query the server's model chose, its rows and a sentence
        made from them, or a refusal saying what the robot can answer. `timeout` (default ASK_TIMEOUT seconds)
        leaves room for the server's first question about a robot, which reads its menu into the model."""
        if not robot:
            raise ValueError("give the robot's name")
        path = f"/ask?{urllib.parse.urlencode({'robot': robot, 'q': question})}"
        answer = self._get(path, "ask", robot, ASK_TIMEOUT if timeout is None else timeout)
        try:
            return Reply(answer["query"], answer["params"], answer["rows"], answer["answer"], answer["confidence"],
                         answer["refused"])
        except (KeyError, TypeError) as e:
            raise QueryFailed("ask", 200, f"the answer is not a reply to a question ({e!r})", self.url) from None

    # --- the bundled queries ---------------------------------------------------------------------

    def cameras(self, robot: str) -> list[CameraLink]:
        """Which of my links are cameras."""
        return [CameraLink(r["link"], _name(r["camera"]), local_name(r["class"])) for r in self.query("cameras", robot)]

    def sensors(self, robot: str) -> list[Sensor]:
        """Every sensor with its class, mount and confidence."""
        return [Sensor(_name(r["sensor"]), local_name(r["class"]), r.get("mount"), _float(r.get("confidence")))
                for r in self.query("sensors", robot)]

    def mounted_below(self, robot: str, link: str) -> list[MountedComponent]:
        """What is mounted on `link` or below it."""
        return [MountedComponent(_name(r["component"]), local_name(r["class"]), r["mount"])
                for r in self.query("mounted_below", robot, link=link)]

    def end_effectors(self, robot: str) -> list[EndEffector]:
        """Each end-effector with its tool centre point and contact surfaces."""
        return [EndEffector(_name(r["endEffector"]), local_name(r["class"]), r.get("mount"), r.get("tcp"),
                            _words(r.get("contacts"))) for r in self.query("end_effectors", robot)]

    def low_confidence(self, robot: str, threshold: float | None = None) -> list[ReviewItem]:
        """Components and sub-components classified with less confidence than `threshold` (None: the server's
        review threshold), least first."""
        out = []
        for r in self.query("low_confidence", robot, threshold=threshold):
            local = local_name(r["individual"])
            subpart = local.startswith("sub_")
            owner = local.removeprefix("sub_").split(".", 1)[0] if subpart else local
            out.append(ReviewItem(_name(owner), local_name(r["class"]), float(r["confidence"]), r["link"], subpart))
        return out

    def components(self, robot: str) -> list[Component]:
        """Every component (the `components` query: sensors and end-effectors) with class, confidence, mount and
        sub-components."""
        comps: dict[str, dict] = {}
        for r in self.query("components", robot):
            c = comps.setdefault(r["component"], {"name": _name(r["component"]), "cls": local_name(r["class"]),
                                                  "confidence": _float(r.get("confidence")), "mount": r.get("mount"),
                                                  "subparts": []})
            if "sub" in r:
                c["subparts"].append(SubPart(local_name(r["subClass"]), r.get("subLink"), _float(r.get("subConfidence"))))
        return [Component(**{**c, "subparts": tuple(c["subparts"])}) for c in comps.values()]

    def body_parts(self, robot: str) -> list[BodyPart]:
        """Each body part with its class, side, parent part, mount and joints (root-most first)."""
        parts: dict[str, dict] = {}
        for r in self.query("body_parts", robot):
            p = parts.setdefault(r["bodyPart"], {
                "name": r.get("name") or _name(r["bodyPart"]), "cls": local_name(r["class"]), "label": r.get("classLabel"),
                "side": r.get("side"), "parent": _name(r["parent"]) if "parent" in r else None, "mount": r.get("mount"),
                "confidence": _float(r.get("confidence")), "joints": []})
            if "joint" in r and r["joint"] not in p["joints"]:
                p["joints"].append(r["joint"])
        return [BodyPart(**{**p, "joints": tuple(p["joints"])}) for p in parts.values()]

    def body_part_joints(self, robot: str, part: str, side: str | None = None) -> list[Joint]:
        """The movable joints of the robot's `part` (a body-part class: "arm", "head", "leg", "torso", "wheel",
        "mobile base") on `side` ("left", "right"; None: every side), root-most first. "Which joints move
        your left arm" is `body_part_joints(robot, "arm", "left")`."""
        rows = self.query("body_part_joints", robot, part=part, side=_side(side))
        return [Joint(r["joint"], r.get("type"), _float(r.get("lower")), _float(r.get("upper")), _float(r.get("velocity")),
                      _float(r.get("effort")), _axis(r), r.get("name") or _name(r["bodyPart"]), r.get("side"))
                for r in rows]

    def located_on(self, robot: str, part: str, side: str | None = None) -> list[LocatedComponent]:
        """The sensors and end-effectors located on the robot's `part` (as in `body_part_joints`) on `side`.
        "What is on your head" is `located_on(robot, "head")`."""
        return [LocatedComponent(r.get("name") or _name(r["component"]), local_name(r["class"]), r.get("classLabel"),
                                 r.get("mount"), _name(r["bodyPart"]), r.get("side"))
                for r in self.query("located_on", robot, part=part, side=_side(side))]

    def arm_end_effector(self, robot: str, side: str | None = None) -> list[ArmEndEffector]:
        """Each arm on `side` (None: every arm) with the end-effector at its end, or None where it carries none."""
        out = []
        for r in self.query("arm_end_effector", robot, side=_side(side)):
            tool = None
            if "endEffector" in r:
                tool = EndEffector(r.get("name") or _name(r["endEffector"]), local_name(r["class"]), r.get("mount"), r.get("tcp"),
                                   _words(r.get("contacts")), r.get("classLabel"), _words(r.get("joints")))
            out.append(ArmEndEffector(r.get("armName") or _name(r["arm"]), r.get("side"), tool))
        return out

    def camera_frames(self, robot: str) -> list[CameraFrame]:
        """Each camera's optical frames with their modality, and the camera's field of view, image size and
        rate where its simulator declaration states them. "What can you see?" reads these."""
        return [CameraFrame(_name(r["camera"]), local_name(r["class"]), r["frame"], local_name(r["modality"]),
                            r.get("modalityLabel"), _float(r.get("fov")), _int(r.get("width")), _int(r.get("height")),
                            _float(r.get("rate")), _words(r.get("referenceFrames")))
                for r in self.query("camera_frames", robot)]

    def arm_reach(self, robot: str, side: str | None = None) -> list[ArmReach]:
        """Each arm on `side` (None: every arm) with its degrees of freedom and reach in metres."""
        return [ArmReach(r.get("name") or _name(r["arm"]), r.get("side"), r.get("mount"), _int(r.get("degreesOfFreedom")),
                         _float(r.get("reach"))) for r in self.query("arm_reach", robot, side=_side(side))]

    def gripper_opening(self, robot: str) -> list[GripperOpening]:
        """Each gripper with the arm it is on and its maximum opening in metres (None where its finger joints
        give none)."""
        return [GripperOpening(r.get("name") or _name(r["gripper"]), local_name(r["class"]), r.get("classLabel"),
                               r.get("mount"), _name(r["arm"]) if "arm" in r else None, r.get("side"),
                               _float(r.get("opening"))) for r in self.query("gripper_opening", robot)]

    # --- populating ------------------------------------------------------------------------------

    def populate(self, urdf: bytes | str | os.PathLike, name: str | None = None, *, filename: str | None = None,
                 structure_only: bool = False) -> dict:
        """Send a URDF or xacro document (bytes, or a file's path) to be populated (POST /populate): the job
        the server started, as it describes it (`id`, `state`, ...; see `job`). `name` names the robot (default:
        the URDF's), `filename` the document (default: the file's name; `.xacro` means xacro);
        `structure_only` skips the model. A document over the server's body limit raises TooLarge, unsent."""
        if isinstance(urdf, bytes):
            what, size = filename or "the document", len(urdf)
        else:
            what = os.fspath(urdf)
            size, filename = os.path.getsize(what), filename or os.path.basename(what)
        limit = self.max_body()
        if limit is not None and size > limit:
            raise TooLarge(what, size, limit, self.url)
        if isinstance(urdf, bytes):
            data = urdf
        else:
            with open(urdf, "rb") as f:
                data = f.read()
        params = {"name": name, "filename": filename, "structure_only": "true" if structure_only else None}
        query = urllib.parse.urlencode({k: v for k, v in params.items() if v is not None})
        return self._json(self._request("/populate" + (f"?{query}" if query else ""), "populate", data=data,
                                        headers={"Content-Type": "application/xml"})[0], "populate")

    def job(self, job_id: str, wait: bool = False) -> dict:
        """A populate job as the server describes it (`state`: queued, running, succeeded or failed; `robot`,
        `errors`...); with `wait`, once it has finished (or after the server's wait, at most 30 s)."""
        path = f"/jobs/{urllib.parse.quote(job_id, safe='')}" + ("?wait=1" if wait else "")
        return self._json(self._request(path, "job")[0], "job")

    def max_body(self) -> int | None:
        """The most bytes a request body may have on the server (None: a server that does not say)."""
        value = self._request("/populate", "populate", method="OPTIONS")[1].get(MAX_BODY_HEADER)
        return int(value) if value and value.isdigit() else None

    # --- HTTP ------------------------------------------------------------------------------------

    def _get(self, path: str, what: str, robot: str | None = None, timeout: float | None = None):
        """The JSON answer of GET `path` (within `timeout` seconds, default the client's); the errors above otherwise."""
        return self._json(self._request(path, what, robot, timeout=timeout)[0], what)

    def _json(self, body: bytes, what: str):
        try:
            return json.loads(body)
        except ValueError:
            raise QueryFailed(what, 200, "the answer is not JSON", self.url) from None

    def _request(self, path: str, what: str, robot: str | None = None, method: str | None = None,
                 data: bytes | None = None, headers: dict[str, str] | None = None,
                 timeout: float | None = None) -> tuple[bytes, http.client.HTTPMessage]:
        """The body and headers of the answer to `method` (GET, or POST with `data`) `path` within `timeout`
        seconds (default the client's); the errors above otherwise."""
        timeout = self.timeout if timeout is None else timeout
        headers = {"Accept": "application/sparql-results+json, application/json;q=0.9",
                   "User-Agent": f"urdfkb-client/{__version__}", **(headers or {})}
        if self.token:
            headers["Authorization"] = f"Bearer {self.token}"
        request = urllib.request.Request(self.url + path, data=data, headers=headers, method=method)
        try:
            with _OPENER.open(request, timeout=timeout) as response:
                return response.read(), response.headers
        except urllib.error.HTTPError as e:
            message = _redirect(e) if 300 <= e.code < 400 else _message(e)
            if e.code == 404 and robot is not None and message.startswith("no robot"):
                raise UnknownRobot(robot, self.url) from None
            raise QueryFailed(what, e.code, message, self.url) from None
        except urllib.error.URLError as e:
            raise ServerUnavailable(self.url, _reason(e.reason)) from None
        except TimeoutError:
            raise ServerUnavailable(self.url, f"no answer within {timeout:g} s") from None
        except (http.client.HTTPException, OSError) as e:
            raise ServerUnavailable(self.url, _reason(e)) from None


def class_words(cls: str) -> str:
    """An ontology class's local name as words: "MonocularCamera" -> "monocular camera", "RGBDCamera" ->
    "RGBD camera", "IMU" -> "IMU" (acronyms keep their case)."""
    words = re.findall(r"[A-Z]+(?![a-z])|[A-Z]?[a-z]+|[0-9]+", cls) or [cls]
    return " ".join(w if w.isupper() and len(w) > 1 else w.lower() for w in words)


def _message(error: urllib.error.HTTPError) -> str:
    """The server's reason for an error status: its JSON `error`, else the start of its text."""
    try:
        body = error.read(4096)
    except (OSError, http.client.HTTPException):
        return error.reason or ""
    try:
        return str(json.loads(body)["error"])
    except (ValueError, KeyError, TypeError):
        text = body.decode("utf-8", "replace").strip()
        return text[:300] or str(error.reason or "")


def _redirect(error: urllib.error.HTTPError) -> str:
    location = error.headers.get("Location", "")[:300]
    return f"redirected to {location!r}: the client follows no redirect (it would send the token along)"


def _reason(reason) -> str:
    if isinstance(reason, TimeoutError):
        return "no answer in time"
    if isinstance(reason, ConnectionRefusedError):
        return "connection refused"
    return str(reason) or type(reason).__name__


def _name(iri: str) -> str:
    """A component's or body part's name from its individual IRI (`comp_<name>`, `body_<name>`, escaped)."""
    local = local_name(iri)
    for prefix in ("comp_", "body_"):
        if local.startswith(prefix):
            local = local[len(prefix):]
            break
    return urllib.parse.unquote(local, encoding="utf-8", errors="surrogatepass")  # pipeline.knowledge.namespaces.escape, undone


def _float(text: str | None) -> float | None:
    return float(text) if text not in (None, "") else None


def _int(text: str | None) -> int | None:
    return int(text) if text not in (None, "") else None


def _words(text: str | None) -> tuple[str, ...]:
    return tuple(sorted(text.split())) if text else ()


def _axis(row: dict) -> tuple[float, float, float] | None:
    try:
        return (float(row["axisX"]), float(row["axisY"]), float(row["axisZ"]))
    except KeyError:
        return None


def _side(side: str | None) -> str | None:
    if side is None:
        return None
    if side.lower() not in SIDES:
        raise ValueError(f"side must be 'left', 'right' or None, got {side!r}")
    return side.lower()
