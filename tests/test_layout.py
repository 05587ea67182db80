"""One import name per module (docs/layout.md): absolute imports only, no sys.path edits, a mapped folder
refuses its bare name, and the type checker's view of the package (.import-root) matches package-dir."""
import ast
import functools
import subprocess
import sys
import tomllib
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
PACKAGE_DIR = tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["setuptools"]["package-dir"]
SOURCES = sorted(p for folder in [*PACKAGE_DIR.values(), "tests", "benchmarks", "examples"]
                 for p in (REPO / folder).rglob("*.py"))


@functools.cache
def _nodes() -> list[tuple[str, ast.AST]]:
    return [(f"{path.relative_to(REPO)}:{getattr(node, 'lineno', 0)}", node)
            for path in SOURCES for node in ast.walk(ast.parse(path.read_text(), str(path)))]


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


def test_import_root_lays_out_the_installed_package():
    root = REPO / ".import-root"
    for package, folder in PACKAGE_DIR.items():
        if package != "urdfkb":
            link = root.joinpath(*package.split("."))
            assert link.is_symlink() and link.resolve() == (REPO / folder).resolve(), package
    modules = {p.name for p in (REPO / "urdfkb").glob("*.py")}
    for name in modules:
        assert (root / "urdfkb" / name).resolve() == REPO / "urdfkb" / name
    assert {p.name for p in (root / "urdfkb").iterdir()} == {
        *modules, *(p.split(".", 1)[1] for p in PACKAGE_DIR if p != "urdfkb")}
