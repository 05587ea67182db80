"""One error path: every UrdfkbError subclass states its HTTP status, and the server answers any of them raised
in a route the same way (kb_server.replies.handle_error): JSON for the API, a page for a browser's GET."""
import importlib
import pkgutil
from collections.abc import Iterator

import pytest

import urdfkb
from tests.kb_fixtures import make_app
from urdfkb.kb_server.store import Store
from urdfkb.pipeline.errors import UrdfkbError

# What each error is answered with: a new subclass fails the first test below until it is listed here.
STATUS = {
    "urdfkb.pipeline.errors.URDFError": 400,
    "urdfkb.pipeline.reading.tree.TreeError": 400,
    "urdfkb.pipeline.reading.xacro_input.XacroError": 400,
    "urdfkb.pipeline.errors.OntologyError": 500,
    "urdfkb.pipeline.errors.BackendError": 502,
    "urdfkb.pipeline.errors.SettingsError": 400,
    "urdfkb.pipeline.errors.CorrectionError": 400,
    "urdfkb.pipeline.errors.ShapeError": 400,
    "urdfkb.pipeline.reading.sandbox.Unavailable": 403,
    "urdfkb.kb_server.errors.BadRequest": 400,
    "urdfkb.kb_server.errors.Forbidden": 403,
    "urdfkb.kb_server.errors.NotFound": 404,
    "urdfkb.kb_server.errors.UnsupportedMediaType": 415,
    "urdfkb.kb_server.errors.TooManyRequests": 429,
    "urdfkb.kb_server.errors.StorageFault": 503,
    "urdfkb.kb_server.errors.DiskFull": 507,
    "urdfkb.kb_server.errors.ServiceUnavailable": 503,
    "urdfkb.kb_server.ask.QuestionError": 400,
    "urdfkb.kb_server.mcp_tools.ToolError": 400,
    "urdfkb.kb_server.jobs.QueueFull": 429,
    "urdfkb.kb_server.remote.RemoteError": 502,
    "urdfkb.kb_server.results.ResultTooLarge": 413,
    "urdfkb.kb_server.sparql.QueryError": 400,
    "urdfkb.kb_server.sparql.QueryTimeout": 503,
    "urdfkb.kb_server.sparql.NotAcceptable": 406,
    "urdfkb.kb_server.index.WorkerCrashed": 500,
    "urdfkb.kb_server.index.QueryOutOfMemory": 503,
    "urdfkb.kb_server.index.IndexClosed": 503,
    "urdfkb.kb_server.store.ReadOnlyGraph": 403,
    "urdfkb.kb_server.store.RobotNameError": 400,
    "urdfkb.kb_server.store.UnknownRobot": 404,
    "urdfkb.kb_server.queries.ParamError": 400,
    "urdfkb.kb_server.queries.UnknownQuery": 404,
    "urdfkb.kb_server.json_body.BadJSON": 400,
}
# Constructor arguments where a class takes more than its message.
ARGS = {"ShapeError": ("broken", ["a shape's violation"]), "TreeError": ("a cycle", "link 'a'"),
        "TooManyRequests": ("busy", 7), "QueueFull": ("full", 30)}


def _name(cls: type) -> str:
    return f"{cls.__module__}.{cls.__qualname__}"


def _subclasses(cls: type[UrdfkbError]) -> Iterator[type[UrdfkbError]]:
    for sub in cls.__subclasses__():
        yield sub
        yield from _subclasses(sub)


for _module in pkgutil.walk_packages(urdfkb.__path__, "urdfkb."):  # every class defined (but the CLI's entry point)
    if not _module.name.endswith("__main__"):
        importlib.import_module(_module.name)
ERRORS = {_name(c): c for c in _subclasses(UrdfkbError) if c.__module__.startswith("urdfkb.")}


@pytest.fixture(scope="module")
def app(tmp_path_factory):
    """The server's app with one more route, raising the error class it names."""
    store = Store(tmp_path_factory.mktemp("kb") / "kb.sqlite3", workers=0)
    app, jobs = make_app(store)

    @app.route("/raise/<name>", methods=["GET", "POST"])
    def raise_error(name: str):
        cls = ERRORS[name]
        raise cls(*ARGS.get(cls.__name__, (f"{cls.__name__} for the client",)))

    yield app
    jobs.shutdown()
    store.close()


def test_every_error_class_is_listed_and_states_its_status():
    assert set(ERRORS) == set(STATUS)
    assert [name for name, cls in ERRORS.items() if "status" not in vars(cls)] == []


@pytest.mark.parametrize("name", sorted(STATUS))
def test_each_error_raised_in_a_route_answers_its_status_and_message(app, name):
    cls = ERRORS[name]
    r = app.test_client().post(f"/raise/{name}", headers={"X-Requested-With": "test"})
    error = cls(*ARGS.get(cls.__name__, (f"{cls.__name__} for the client",)))
    assert (r.status_code, r.mimetype, r.get_json()) == (STATUS[name], "application/json", {"error": str(error)})
    assert r.headers.get("Retry-After") == (str(ARGS[cls.__name__][1]) if STATUS[name] == 429 else None)


def test_a_browser_gets_the_error_as_a_page(app):
    browser = {"Accept": "text/html,application/xhtml+xml,application/xml;q=0.9,*/*;q=0.8"}
    r = app.test_client().get("/raise/urdfkb.kb_server.store.UnknownRobot", headers=browser)
    assert r.status_code == 404 and r.mimetype == "text/html"
    assert "UnknownRobot for the client" in r.get_data(as_text=True)
    r = app.test_client().get("/robots/ghost", headers=browser)
    assert r.status_code == 404 and "no robot &#39;ghost&#39; in the store" in r.get_data(as_text=True)
