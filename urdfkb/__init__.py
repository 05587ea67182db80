"""urdfkb: turn a robot's URDF into a populated, queryable OWL ontology of its sensors and end-effectors.

The distribution installs this one top-level package. Its sub-packages keep their own folders at the
repository's top level (`pipeline/`, `kb_server/`, `ontologies/`, `queries/`) and are reached as
`urdfkb.<folder>` through the symlinks beside this file (`urdfkb/pipeline -> ../pipeline`, ...), so the
repository keeps one folder per part, a plain checkout imports as the installed package, and
site-packages holds only `urdfkb`.
"""

__version__ = "0.2.0"


def local_name(iri: str) -> str:
    """What follows an IRI's last '#' (the whole IRI where it has none): a class's or an individual's name
    in its ontology. It lives in the package's root, which imports nothing, because the client (standard
    library only) shares it with the server and the pipeline."""
    return iri.rsplit("#", 1)[-1]


def check_package_name(name: str, folder: str) -> None:
    """ImportError unless a mapped folder's package `name` is `urdfkb.<folder>`: imported by its folder's
    own name (the repository on sys.path), every module would load a second time, under a second name,
    with its own copy of each class and cache."""
    if name != f"urdfkb.{folder}":
        raise ImportError(f"{folder}/ is the package urdfkb.{folder}: import it by that name from a checkout "
                          f"(make install, or the repository on sys.path), not as {name!r} with the repository on sys.path")
