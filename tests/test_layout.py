"""One import name per module (docs/layout.md): absolute imports only, no sys.path edits, a mapped folder
refuses its bare name, and urdfkb/ reaches each sub-package's folder through a committed symlink."""
import pytest
import ast
import functools
import subprocess
import sys
import tomllib
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
PACKAGES = tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["setuptools"]["packages"]
# urdfkb.<folder> -> <folder>/ for every sub-package with a folder of its own at the top level
PACKAGE_DIR = {"urdfkb": "urdfkb", **{p: p.split(".")[1] for p in PACKAGES if p.count(".") == 1}}
SOURCES = sorted(p for folder in [*PACKAGE_DIR.values(), "tests", "benchmarks", "examples"]
                 for p in (REPO / folder).rglob("*.py"))


@functools.cache
def _nodes() -> list[tuple[str, ast.AST]]:
    return [(f"{path.relative_to(REPO)}:{getattr(node, 'lineno', 0)}", node)
            for path in SOURCES for node in ast.walk(ast.parse(path.read_text(), str(path)))]


@pytest.mark.slow  # over a second of its own (make test-fast leaves it out)
def test_every_import_is_absolute():
    assert [where for where, node in _nodes() if isinstance(node, ast.ImportFrom) and node.level] == []


def test_nothing_touches_sys_path():
    touched = [where for where, node in _nodes() if isinstance(node, ast.Attribute) and node.attr == "path"
               and isinstance(node.value, ast.Name) and node.value.id == "sys"]
    assert touched == []


def test_a_mapped_folder_refuses_its_own_name():
    for folder in ("pipeline", "kb_server"):
        proc = subprocess.run([sys.executable, "-c", f"import {folder}"], cwd=REPO, capture_output=True, text=True)
        assert proc.returncode == 1 and f"{folder}/ is the package urdfkb.{folder}" in proc.stderr, proc.stderr


def test_urdfkb_links_each_folder_it_ships():
    """urdfkb/<folder> is a relative symlink to the top-level folder, and nothing else in urdfkb/ is a link."""
    for package, folder in PACKAGE_DIR.items():
        if package != "urdfkb":
            link = REPO / "urdfkb" / folder
            assert link.is_symlink() and str(link.readlink()) == f"../{folder}", package
    links = {p.name for p in (REPO / "urdfkb").iterdir() if p.is_symlink()}
    assert links == {folder for package, folder in PACKAGE_DIR.items() if package != "urdfkb"}


def test_every_package_folder_is_shipped():
    """Each folder with an __init__.py under a shipped folder is in pyproject's package list (a new sub-package
    left out would be missing from the wheel)."""
    for package, folder in PACKAGE_DIR.items():
        if package == "urdfkb":
            continue
        for init in (REPO / folder).rglob("__init__.py"):
            parts = init.parent.relative_to(REPO / folder).parts
            assert ".".join((package, *parts)) in PACKAGES, init.parent


def test_a_plain_checkout_imports_the_package():
    """No install and no site packages' import hook: the checkout alone resolves urdfkb.pipeline.runner to its file."""
    proc = subprocess.run([sys.executable, "-S", "-c",
                           "import importlib.util as u; print(u.find_spec('urdfkb.pipeline.runner').origin)"],
                          cwd=REPO, env={"PYTHONPATH": str(REPO)}, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    assert Path(proc.stdout.strip()).resolve() == REPO / "pipeline" / "runner.py"


# --- one RDF seam (pipeline/knowledge/rdf.py, docs/layout.md) ------------------------------------------------
SEAM = REPO / "pipeline" / "knowledge" / "rdf.py"
PRODUCT = [p for p in SOURCES if p.relative_to(REPO).parts[0] in PACKAGE_DIR.values()]
# Underscore names the product uses that owlready2 also defines, on objects that are not owlready2's.
NOT_OWLREADY = {("pipeline/llm/llama.py", "_name")}  # a ctypes library's file name


def _owlready_internals() -> set[str]:
    """Every attribute name of owlready2's internals: the underscore names its classes define and a world, its
    quadstore, an ontology and an individual hold, and two public names that are internals all the same (`storid`,
    an entity's row in the quadstore; `db`, the quadstore's SQLite connection). Asked of the installed owlready2,
    so a new version's names are covered."""
    import owlready2
    world = owlready2.World()
    onto = world.get_ontology("urn:layout#")
    with onto:
        thing = owlready2.Thing("thing")
    names = {"storid", "db"}
    for module in [m for name, m in sys.modules.items() if name.split(".")[0] == "owlready2"]:
        for value in vars(module).values():
            if isinstance(value, type) and value.__module__.split(".")[0] == "owlready2":
                names.update(dir(value))
    for instance in (world, world.graph, onto, thing):
        names.update(vars(instance))
    world.close()
    return {n for n in names if n in ("storid", "db") or (n.startswith("_") and not n.endswith("__"))}


def test_only_the_seam_imports_owlready2():
    """pipeline/knowledge/rdf.py alone (stricter than the issue's "the seam and the store": the store needs no more)."""
    importing = {path.relative_to(REPO).as_posix() for path in PRODUCT for node in ast.walk(ast.parse(path.read_text()))
                 if isinstance(node, ast.Import) and any(a.name.split(".")[0] == "owlready2" for a in node.names)
                 or isinstance(node, ast.ImportFrom) and (node.module or "").split(".")[0] == "owlready2"}
    assert importing == {"pipeline/knowledge/rdf.py"}


def test_only_the_seam_touches_owlready2_internals():
    """No attribute of owlready2's internals is read or written outside the seam. Attributes of `self` and `cls`
    are the module's own: no product class outside the seam derives from an owlready2 class (the next test), and
    only the seam can name one (the test before)."""
    internals = _owlready_internals()
    touched = []
    for path in PRODUCT:
        where = path.relative_to(REPO).as_posix()
        for node in ast.walk(ast.parse(path.read_text())):
            if (path != SEAM and isinstance(node, ast.Attribute) and node.attr in internals
                    and not (isinstance(node.value, ast.Name) and node.value.id in ("self", "cls"))
                    and (where, node.attr) not in NOT_OWLREADY):
                touched.append(f"{where}:{node.lineno} .{node.attr}")
    assert touched == []
    assert "_abbreviate" in internals and "_add_obj_triple_spo" in internals  # the check knows what it looks for


def test_no_class_outside_the_seam_derives_from_its_types():
    derived = []
    for path in PRODUCT:
        tree = ast.parse(path.read_text())
        seam_names = {a.asname or a.name for node in ast.walk(tree) if isinstance(node, ast.ImportFrom)
                      and node.module == "urdfkb.pipeline.knowledge.rdf" for a in node.names}
        for node in ast.walk(tree):
            if path != SEAM and isinstance(node, ast.ClassDef):
                for base in node.bases:
                    if (isinstance(base, ast.Name) and base.id in seam_names
                            or isinstance(base, ast.Attribute) and isinstance(base.value, ast.Name) and base.value.id == "rdf"):
                        derived.append(f"{path.relative_to(REPO)}:{node.lineno}")
    assert derived == []


def test_the_layout_page_lists_every_module_and_no_other():
    """docs/layout.md's module table names each .py file of urdfkb/ (its own), pipeline/ and kb_server/ once."""
    import re
    listed = re.findall(r"^\| `((?:urdfkb|pipeline|kb_server)/[\w/]+\.py)` \|", (REPO / "docs" / "layout.md").read_text(),
                        re.MULTILINE)
    files = sorted(str(p.relative_to(REPO)) for folder in ("pipeline", "kb_server") for p in (REPO / folder).rglob("*.py"))
    files += sorted(f"urdfkb/{p.name}" for p in (REPO / "urdfkb").glob("*.py"))
    assert sorted(listed) == sorted(files) and len(listed) == len(set(listed))
