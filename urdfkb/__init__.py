"""urdfkb: turn a robot's URDF into a populated, queryable OWL ontology of its sensors and end-effectors.

The distribution installs this one top-level package. Its sub-packages keep their own folders at the
repository's top level (`pipeline/`, `kb_server/`, `ontologies/`, `queries/`) and are mapped under
`urdfkb.` by `[tool.setuptools] package-dir` in pyproject.toml, so the repository reads as the design
card lays it out while site-packages holds only `urdfkb`.
"""

__version__ = "0.2.0"
