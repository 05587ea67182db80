"""The HRI SPARQL queries (*.rq), packaged as data; loaded by kb_server.queries."""
from urdfkb import check_package_name

check_package_name(__name__, "queries")
