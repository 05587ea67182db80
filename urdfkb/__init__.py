"""urdfkb: turn a robot's URDF into a populated, queryable OWL ontology of its sensors and end-effectors.

The distribution installs this one top-level package. Its sub-packages keep their own folders at the
repository's top level (`pipeline/`, `kb_server/`, `ontologies/`, `queries/`) and are mapped under
`urdfkb.` by `[tool.setuptools] package-dir` in pyproject.toml, so the repository keeps one folder per
part while site-packages holds only `urdfkb`.
"""

__version__ = "0.2.0"


def check_package_name(name: str, folder: str) -> None:
    """ImportError unless a mapped folder's package `name` is `urdfkb.<folder>`: imported by its folder's
    own name (the repository on sys.path), every module would load a second time, under a second name,
    with its own copy of each class and cache."""
    if name != f"urdfkb.{folder}":
        raise ImportError(f"{folder}/ is the package urdfkb.{folder}: import it by that name from an installed "
                          f"checkout (make install), not as {name!r} with the repository on sys.path")
