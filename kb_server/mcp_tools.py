"""The knowledge base as Model Context Protocol tools and resources (the official `mcp` SDK's low-level Server).

Tools: one per bundled query (queries/*.rq), named as its file, its description and JSON-schema arguments
made from the file's header (`# title`, `# param`, the comment under them), so a new .rq file is a new
tool; `robots`, the stored robots; `sparql`, a read-only query (SELECT, ASK, CONSTRUCT, DESCRIBE) under
the store's limits. Resources: each robot's export, as Turtle. A tool's answer is structured: the columns,
the rows with typed values (numbers as JSON numbers) and the unit of each column whose property names one.
A bad argument, an unknown robot or an update is a tool error (`isError`) whose text names the problem.

`urdfkb mcp` serves these over stdio (kb_server.cli); `urdfkb serve` over streamable HTTP at /mcp
(kb_server.routes.mcp).
"""
from __future__ import annotations

import json
from collections.abc import Mapping
from typing import Any

import anyio
import jsonschema
import mcp_types as types
from mcp.server import Server
from mcp.server.context import ServerRequestContext
from mcp.shared.exceptions import MCPError

from urdfkb import __version__
from urdfkb.kb_server.queries import NamedQuery, load_queries, run_named
from urdfkb.kb_server.rows import table, units
from urdfkb.kb_server.sparql import tokens
from urdfkb.kb_server.store import Store
from urdfkb.pipeline.errors import UrdfkbError
from urdfkb.pipeline.knowledge.formats import N_TRIPLES, TURTLE
from urdfkb.pipeline.knowledge.namespaces import CORE_IRI
from urdfkb.settings import QUERY_TIMEOUT

JSON_TYPES = {"string": "string", "decimal": "number", "integer": "integer"}
QUERY_FORMS = ("SELECT", "ASK", "CONSTRUCT", "DESCRIBE")
RESOURCE_SCHEME = "urdfkb://robots/"
ROBOT_ARG = {"type": "string", "description": "the stored robot's name (the `robots` tool lists them)"}


class ToolError(UrdfkbError, ValueError):
    """A tool call the knowledge base cannot answer as given; the message names the argument or the problem."""

    status = 400


def query_description(query: NamedQuery, text: str) -> str:
    """The title and the comment lines under the header of a query file: what it answers, row by row."""
    notes = [line[1:].strip() for line in text.splitlines()
             if line.startswith("#") and not line.startswith(("# title:", "# param"))]
    return " ".join([query.title + "."] + notes)


def input_schema(query: NamedQuery) -> dict:
    """The JSON schema of a query tool's arguments: `robot` and the query's own parameters, with their defaults."""
    props: dict[str, dict] = {"robot": ROBOT_ARG}
    for p in query.params:
        prop: dict[str, Any] = {"type": JSON_TYPES[p.type], "description": p.doc}
        if p.default is not None:
            prop["default"] = float(p.default) if p.type == "decimal" else int(p.default) if p.type == "integer" \
                else p.default
        props[p.name] = prop
    return {"type": "object", "properties": props, "additionalProperties": False,
            "required": ["robot"] + [p.name for p in query.params if p.default is None]}


def check_arguments(name: str, schema: dict, arguments: Mapping[str, Any]) -> None:
    """ToolError naming the first argument that breaks the tool's schema."""
    error = jsonschema.exceptions.best_match(jsonschema.Draft202012Validator(schema).iter_errors(dict(arguments)))
    if error is not None:
        where = f"argument {'.'.join(map(str, error.absolute_path))!r}: " if error.absolute_path else ""
        raise ToolError(f"tool {name!r}: {where}{error.message}")


def query_form(text: str) -> str | None:
    """The operation's first keyword after its prologue (BASE, PREFIX): SELECT, ASK, ..., or an update's."""
    for kind, tok in tokens(text):
        word = tok.upper()
        if kind == "word" and word not in ("BASE", "PREFIX"):
            return word
    return None


class KnowledgeTools:
    """The tools and resources over one store; every call is synchronous (run it off the event loop)."""

    SPARQL_SCHEMA = {"type": "object", "additionalProperties": False, "required": ["query"],
                     "properties": {"query": {"type": "string", "description": "a SPARQL 1.1 query (SELECT, ASK, "
                                              "CONSTRUCT or DESCRIBE); the default graph is the union of all graphs"}}}

    def __init__(self, store: Store, query_timeout: float = QUERY_TIMEOUT):
        self.store = store
        self.query_timeout = query_timeout
        self.queries = load_queries()

    def tools(self) -> list[types.Tool]:
        read_only = types.ToolAnnotations(read_only_hint=True, destructive_hint=False, idempotent_hint=True,
                                          open_world_hint=False)
        out = [types.Tool(name=q.name, title=q.title, description=query_description(q, q.text),
                          input_schema=input_schema(q), annotations=read_only) for q in self.queries.values()]
        out.append(types.Tool(name="robots", title="The stored robots",
                              description="The robots this knowledge base holds: name, ontology (named graph) IRI, "
                                          "robot individual IRI and when each was last written.",
                              input_schema={"type": "object", "properties": {}, "additionalProperties": False},
                              annotations=read_only))
        out.append(types.Tool(name="sparql", title="A read-only SPARQL query",
                              description="Answer a SPARQL 1.1 query (SELECT, ASK, CONSTRUCT or DESCRIBE) over every "
                                          f"robot and the core ontology <{CORE_IRI}> under the endpoint's time and size "
                                          "limits; updates are refused. CONSTRUCT and DESCRIBE answer N-Triples.",
                              input_schema=self.SPARQL_SCHEMA, annotations=read_only))
        return out

    def call(self, name: str, arguments: Mapping[str, Any]) -> dict:
        """The structured answer of tool `name`; ToolError (or the store's UrdfkbError) for what it cannot answer."""
        if name == "robots":
            check_arguments(name, {"type": "object", "additionalProperties": False}, arguments)
            return {"robots": [e.to_dict() for e in self.store.robots()]}
        if name == "sparql":
            check_arguments(name, self.SPARQL_SCHEMA, arguments)
            return self.sparql(arguments["query"])
        query = self.queries.get(name)
        if query is None:
            raise ToolError(f"no tool {name!r} (tools: {', '.join([*self.queries, 'robots', 'sparql'])})")
        check_arguments(name, input_schema(query), arguments)
        params = {k: str(v) for k, v in arguments.items() if k != "robot"}
        result = run_named(self.store, name, arguments["robot"], params, self.query_timeout)
        return {"query": name, "robot": arguments["robot"], **table(result, units(query.text))}

    def sparql(self, text: str) -> dict:
        form = query_form(text)
        if form not in QUERY_FORMS:
            raise ToolError(f"tool 'sparql' answers queries ({', '.join(QUERY_FORMS)}) only; "
                            f"{form or 'an empty operation'} is refused: the knowledge base is read-only here")
        result = self.store.query(text, self.query_timeout,
                                  N_TRIPLES.media_type if form in ("CONSTRUCT", "DESCRIBE") else None)
        if result.kind == "graph":
            return {"ntriples": result.body.decode("utf-8")}
        if result.kind == "boolean":
            return {"boolean": bool(result.document["boolean"])}
        return table(result)

    def resources(self) -> list[types.Resource]:
        return [types.Resource(name=e.name, uri=f"{RESOURCE_SCHEME}{e.name}.ttl", mime_type=TURTLE.media_type,
                               description=f"robot {e.name}'s self-contained ontology (Turtle), as exported")
                for e in self.store.robots()]

    def read(self, uri: str) -> str:
        name = uri.removeprefix(RESOURCE_SCHEME).removesuffix(".ttl")
        if not uri.startswith(RESOURCE_SCHEME) or not uri.endswith(".ttl") or \
                (data := self.store.export(name, TURTLE.extension)) is None:
            raise ToolError(f"no resource {uri!r} (resources: {RESOURCE_SCHEME}<robot>.ttl for a stored robot)")
        return data.decode("utf-8")


def mcp_server(store: Store, query_timeout: float = QUERY_TIMEOUT) -> Server:
    """The MCP server over `store`; each call runs in a worker thread, so queries never block its event loop."""
    kb = KnowledgeTools(store, query_timeout)

    async def list_tools(ctx: ServerRequestContext, params: types.PaginatedRequestParams | None) -> types.ListToolsResult:
        return types.ListToolsResult(tools=kb.tools())

    async def call_tool(ctx: ServerRequestContext, params: types.CallToolRequestParams) -> types.CallToolResult:
        try:
            answer = await anyio.to_thread.run_sync(kb.call, params.name, params.arguments or {})
        except UrdfkbError as e:
            return types.CallToolResult(content=[types.TextContent(type="text", text=str(e))], is_error=True)
        return types.CallToolResult(content=[types.TextContent(type="text", text=json.dumps(answer))],
                                    structured_content=answer)

    async def list_resources(ctx: ServerRequestContext,
                             params: types.PaginatedRequestParams | None) -> types.ListResourcesResult:
        return types.ListResourcesResult(resources=await anyio.to_thread.run_sync(kb.resources))

    async def read_resource(ctx: ServerRequestContext,
                            params: types.ReadResourceRequestParams) -> types.ReadResourceResult:
        uri = str(params.uri)
        try:
            text = await anyio.to_thread.run_sync(kb.read, uri)
        except UrdfkbError as e:
            raise MCPError(types.INVALID_PARAMS, str(e)) from None
        return types.ReadResourceResult(contents=[types.TextResourceContents(uri=uri, mime_type=TURTLE.media_type,
                                                                              text=text)])

    return Server("urdfkb", version=__version__, title="urdfkb: what a robot knows about its body",
                  instructions="Each tool answers one question about a stored robot's body (its sensors, "
                               "end-effectors, body parts and their reach) from its populated ontology; call "
                               "`robots` first for the robots' names.",
                  on_list_tools=list_tools, on_call_tool=call_tool, on_list_resources=list_resources,
                  on_read_resource=read_resource)


def serve_stdio(store: Store, query_timeout: float = QUERY_TIMEOUT) -> None:
    """Serve the tools over stdin and stdout until the client closes them (`urdfkb mcp`)."""
    from mcp.server.stdio import stdio_server
    server = mcp_server(store, query_timeout)

    async def main() -> None:
        async with stdio_server() as (read, write):
            await server.run(read, write, server.create_initialization_options())
    anyio.run(main)
