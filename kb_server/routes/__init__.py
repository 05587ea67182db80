"""The HTTP API's routes, one blueprint per resource: `sparql` (the SPARQL 1.1 Protocol), `jobs` (populate
and its jobs), `robots`, `queries` (the bundled HRI queries); the pages and corrections are kb_server/ui.py's."""
from urdfkb.kb_server.routes import jobs, queries, robots, sparql

BLUEPRINTS = (sparql.bp, jobs.bp, robots.bp, queries.bp)
