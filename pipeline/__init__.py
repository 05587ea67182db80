"""The library: a URDF's kinematic tree to its components and their ontology (README, Layout)."""
from urdfkb import check_package_name

check_package_name(__name__, "pipeline")
