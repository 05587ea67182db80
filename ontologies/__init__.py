"""The core ontology (urdfkb.owl) and its SHACL shapes (shapes.ttl), packaged as data."""
from urdfkb import check_package_name

check_package_name(__name__, "ontologies")
