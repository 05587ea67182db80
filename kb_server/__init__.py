"""The product: the `urdfkb` command, the HTTP server and its persistent knowledge base (README, Layout)."""
from urdfkb import check_package_name

check_package_name(__name__, "kb_server")
