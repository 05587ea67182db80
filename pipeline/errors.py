"""Errors that cross module boundaries; each names what went wrong and where."""


class UrdfkbError(Exception):
    """Base class: any error urdfkb reports to a user instead of a traceback."""


class URDFError(UrdfkbError):
    """The URDF was refused: not XML, hostile, too large, or structurally invalid."""

    def __init__(self, message: str, element: str | None = None):
        self.element = element
        super().__init__(f"{message} (at {element})" if element else message)


class OntologyError(UrdfkbError):
    """The ontology or a populated robot breaks the vocabulary contract or its shapes."""


class BackendError(UrdfkbError):
    """The model backend failed: it raised, timed out or kept answering outside the valid set."""


class CorrectionError(UrdfkbError, ValueError):
    """A reviewer's correction that does not fit the robot (or is malformed); the message says why."""


class ShapeError(UrdfkbError):
    """A robot that breaks the SHACL shapes; `violations` lists them, one line each (pipeline.shacl)."""

    def __init__(self, message: str, violations: list[str]):
        self.violations = violations
        super().__init__(message)
