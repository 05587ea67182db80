"""The HTTP API's routes, one blueprint per resource: `sparql` (the SPARQL 1.1 Protocol), `jobs` (populate,
re-populate and the jobs), `robots`, `corrections` (reviewers' corrections of a robot), `queries` (the bundled
HRI queries), `mcp` (the same queries as MCP tools), `ask` (a question in words) and `pages` (the index
page). Each reads the server's services per request (kb_server.services); kb_server/ui.py renders the pages."""
from urdfkb.kb_server.routes import ask, corrections, jobs, mcp, pages, queries, robots, sparql

BLUEPRINTS = (pages.bp, sparql.bp, jobs.bp, robots.bp, corrections.bp, queries.bp, mcp.bp, ask.bp)
