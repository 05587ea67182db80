"""The MCP tools through the SDK's own client (mcp.Client): over stdio (`urdfkb mcp`, a subprocess) and over
streamable HTTP (POST /mcp on a live server), on the whole-body PR2 store."""
from __future__ import annotations

import json
import os
import sys
from pathlib import Path

import anyio
import httpx2
import pytest
from mcp import Client, StdioServerParameters
from mcp.client.streamable_http import streamable_http_client

from tests.kb_fixtures import copied, http, served
from urdfkb.kb_server.queries import load_queries
from urdfkb.kb_server.store import Store

REPO = Path(__file__).resolve().parents[1]


async def _exercise(client: Client) -> dict:
    """What the tests check, asked through one connection."""
    async with client:
        tools = await client.list_tools()
        cameras = await client.call_tool("cameras", {"robot": "pr2"})
        reach = await client.call_tool("arm_reach", {"robot": "pr2", "side": "left"})
        malformed = await client.call_tool("arm_reach", {"robot": "pr2", "side": 3})
        unknown_param = await client.call_tool("cameras", {"robot": "pr2", "colour": "red"})
        update = await client.call_tool("sparql", {"query": "PREFIX x: <urn:x#> INSERT DATA { x:a x:b x:c }"})
        ask = await client.call_tool("sparql", {"query": "ASK { ?s ?p ?o }"})
        robots = await client.call_tool("robots", {})
        resources = await client.list_resources()
        export = await client.read_resource("urdfkb://robots/pr2.ttl")
    return {"tools": tools.tools, "cameras": cameras, "reach": reach, "malformed": malformed,
            "unknown_param": unknown_param, "update": update, "ask": ask, "robots": robots,
            "resources": resources.resources, "export": export}


def _check(got: dict) -> None:
    names = {t.name for t in got["tools"]}
    assert names == set(load_queries()) | {"robots", "sparql"}
    reach_tool = next(t for t in got["tools"] if t.name == "arm_reach")
    assert reach_tool.input_schema["properties"]["side"] == {
        "type": "string", "default": "any",
        "description": load_queries()["arm_reach"].params[0].doc}
    assert reach_tool.input_schema["required"] == ["robot"]
    assert "How far each arm reaches" in (reach_tool.description or "")

    cameras = got["cameras"]
    assert not cameras.is_error
    links = {row["link"] for row in cameras.structured_content["rows"]}
    assert {"r_forearm_cam_optical_frame", "head_mount_kinect_rgb_optical_frame"} <= links  # the fixture's forearm camera, Kinect
    assert json.loads(cameras.content[0].text) == cameras.structured_content

    reach = got["reach"]
    assert not reach.is_error
    (row,) = reach.structured_content["rows"]
    assert row["side"] == "left" and row["degreesOfFreedom"] == 7 and isinstance(row["reach"], float)
    assert 0.8 < row["reach"] < 1.2
    assert reach.structured_content["units"] == {"reach": "m"}

    assert got["malformed"].is_error and "'side'" in got["malformed"].content[0].text
    assert got["unknown_param"].is_error and "'colour'" in got["unknown_param"].content[0].text
    assert got["update"].is_error and "INSERT is refused" in got["update"].content[0].text
    assert got["ask"].structured_content == {"boolean": True}
    assert "pr2" in {r["name"] for r in got["robots"].structured_content["robots"]}
    assert "urdfkb://robots/pr2.ttl" in {str(r.uri) for r in got["resources"]}
    assert "@prefix" in got["export"].contents[0].text


@pytest.mark.slow
def test_stdio(whole_pr2_kb, tmp_path):
    kb = copied(whole_pr2_kb, tmp_path)
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    params = StdioServerParameters(command=sys.executable, args=["-m", "urdfkb", "mcp", "--store", str(kb)], env=env)
    _check(anyio.run(_exercise, Client(params)))


@pytest.fixture(scope="module")
def live_store(whole_pr2_kb, tmp_path_factory):
    s = Store(copied(whole_pr2_kb, tmp_path_factory.mktemp("kb")), workers=0)
    yield s
    s.close()


@pytest.mark.slow  # over a second of its own (make test-fast leaves it out)
def test_http(live_store):
    with served(live_store) as base:
        _check(anyio.run(_exercise, Client(base + "/mcp")))


def _with_headers(url: str, headers: dict) -> Client:
    return Client(streamable_http_client(url, http_client=httpx2.AsyncClient(headers=headers, timeout=60)))


@pytest.mark.slow  # over a second of its own (make test-fast leaves it out)
def test_http_needs_the_token_where_the_server_has_one(live_store):
    with served(live_store, token="s3cret") as base:
        status, _, body = http("POST", base + "/mcp", b"{}", {"Content-Type": "application/json"})
        assert status == 403 and b"token" in body
        got = anyio.run(_exercise, _with_headers(base + "/mcp", {"Authorization": "Bearer s3cret"}))
        assert not got["cameras"].is_error


def test_http_refuses_another_origin_and_get(live_store):
    with served(live_store) as base:
        status, _, body = http("POST", base + "/mcp", b"{}", {"Content-Type": "application/json",
                                                             "Origin": "http://evil.example"})
        assert status == 403 and b"Origin" in body
        status, _, _ = http("GET", base + "/mcp")
        assert status == 405
