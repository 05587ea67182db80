"""Errors that cross module boundaries; each names what went wrong and where.

Every error urdfkb reports is a UrdfkbError: the command line prints its message, and the server answers
it with the class's `status` and the message as the body (kb_server.replies.handle_error), so the message
is written for whoever sent the input. Each subclass states its status; tests/test_errors.py raises every
subclass through a route and checks it.
"""


class UrdfkbError(Exception):
    """Base class: any error urdfkb reports to a user instead of a traceback (500 from the server: the
    server's own fault, e.g. a bad option at startup)."""

    status = 500

    @property
    def headers(self) -> dict[str, str]:
        """Headers the server's answer to this error carries besides its status (e.g. Retry-After)."""
        return {}


class URDFError(UrdfkbError):
    """The URDF was refused: not XML, hostile, too large, or structurally invalid."""

    status = 400

    def __init__(self, message: str, element: str | None = None):
        self.element = element
        super().__init__(f"{message} (at {element})" if element else message)


class OntologyError(UrdfkbError):
    """The ontology or a populated robot breaks the vocabulary contract or its shapes."""

    status = 500


class BackendError(UrdfkbError):
    """The model backend failed: it raised, timed out or kept answering outside the valid set."""

    status = 502


class SettingsError(UrdfkbError, ValueError):
    """Pipeline settings sent by a client that are not valid; the message names the setting."""

    status = 400

    def __init__(self, problem: str):
        super().__init__(f"bad pipeline settings: {problem}")


class CorrectionError(UrdfkbError, ValueError):
    """A reviewer's correction that does not fit the robot (or is malformed); the message says why."""

    status = 400


class ShapeError(UrdfkbError):
    """A robot that breaks the SHACL shapes; `violations` lists them, one line each (pipeline.knowledge.shacl)."""

    status = 400

    def __init__(self, message: str, violations: list[str]):
        self.violations = violations
        super().__init__(message)
