"""The HRI SPARQL queries (*.rq), packaged as data; loaded by kb_server.queries."""
