"""Bounded work per request (issue 39, cases 5-8): what a large correction, a hostile parameter and exports of
a large robot cost the server, and what they cost other clients.

Usage: python -m benchmarks.request_bounds_bench [--links 5000] [--chain 1500] [--clients 8] [--seconds 20]
       [--store PATH]

Starts `urdfkb serve --token` on a free loopback port (over --store, kept, or a fresh store), populates
structure only, where the store lacks them, a robot of LINKS links (a base and 50 arms) and a chain of
CHAIN links, then prints:
- `/queries/low_confidence?threshold=1e999999999`: its status, time and the server's memory growth;
- the large robot's first export (.owl: made, then kept) and a second one;
- an `add` correction over every link of the chain but its root, while another client exports the large
  robot (.owl, as kept, and .nt, made afresh): their times;
- the chain's corrections (`GET /robots/chain/corrections`) and its page, twice each;
- a correction naming a million made-up links: its status, time and reply size;
- a populate of the small robot (POST to its job's end) and `ASK {}` while CLIENTS clients export the large
  robot (.owl) in a loop for SECONDS seconds, and how many exports they made.
Every request goes to 127.0.0.1 only; every loop is bounded in count and time.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import threading
import time
import urllib.error
import urllib.parse
import urllib.request
from pathlib import Path

from benchmarks.security_bench import free_port, rss_mb

URDFKB = Path(sys.executable).with_name("urdfkb")
TOKEN = "bench-token"
AUTH = {"Authorization": f"Bearer {TOKEN}"}


def call(url: str, data: bytes | None = None, headers: dict | None = None, timeout: float = 300.0) -> tuple[int, bytes, float]:
    """(status, body, seconds) of one request; status 0 if it timed out."""
    started = time.perf_counter()
    req = urllib.request.Request(url, data=data, headers=headers or {})
    try:
        with urllib.request.urlopen(req, timeout=timeout) as resp:
            return resp.status, resp.read(), time.perf_counter() - started
    except urllib.error.HTTPError as e:
        return e.code, e.read(), time.perf_counter() - started
    except TimeoutError:
        return 0, b"", time.perf_counter() - started


def robot(name: str, arms: int, links_in_all: int) -> bytes:
    """A URDF of `links_in_all` links: a base with `arms` chains of revolute links, as long as each other."""
    links, joints = ['<link name="base"/>'], []
    length, longer = divmod(links_in_all - 1, arms)
    for a in range(arms):
        parent = "base"
        for i in range(length + (a < longer)):
            link = f"a{a}_l{i}"
            links.append(f'<link name="{link}"/>')
            joints.append(f'<joint name="a{a}_j{i}" type="revolute"><parent link="{parent}"/><child link="{link}"/>'
                          '<origin xyz="0 0 0.1"/><axis xyz="0 0 1"/>'
                          '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint>')
            parent = link
    return f'<robot name="{name}">{"".join(links)}{"".join(joints)}</robot>'.encode()


def populate(base: str, name: str, urdf: bytes) -> float:
    """Seconds from POST /populate (structure only) to the end of its job; SystemExit if it fails."""
    started = time.perf_counter()
    status, body, _ = call(f"{base}/populate?structure_only=true&name={name}", urdf,
                           {"Content-Type": "application/xml", **AUTH})
    job = json.loads(body)
    while job.get("state") in ("queued", "running"):
        _, body, _ = call(f"{base}/jobs/{job['id']}?wait=1")
        job = json.loads(body)
    if job.get("state") != "succeeded":
        raise SystemExit(f"populating {name} failed: {status} {job}")
    return time.perf_counter() - started


def made_up(n: int) -> list[str]:
    """`n` distinct short link names (base 36, as short as they can be: a body under the 10 MB limit)."""
    digits = "0123456789abcdefghijklmnopqrstuvwxyz"

    def name(i: int) -> str:
        out = ""
        while True:
            i, d = divmod(i, 36)
            out += digits[d]
            if not i:
                return out
    return [name(i) for i in range(n)]


def correction(base: str, name: str, body: dict) -> tuple[int, bytes, float]:
    return call(f"{base}/robots/{name}/corrections", json.dumps(body, separators=(",", ":")).encode(),
                {"Content-Type": "application/json", **AUTH})


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--links", type=int, default=5000, help="links of the large robot")
    parser.add_argument("--chain", type=int, default=1500, help="links of the chain")
    parser.add_argument("--clients", type=int, default=8, help="clients exporting the large robot at once")
    parser.add_argument("--seconds", type=float, default=20.0, help="how long they export")
    parser.add_argument("--store", type=Path, help="a store to keep (populated once: a 5,000-link robot takes minutes)")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        port = free_port()
        base = f"http://127.0.0.1:{port}"
        server = subprocess.Popen([str(URDFKB), "serve", "--store", str(args.store or Path(tmp) / "kb.sqlite3"), "--port", str(port),
                                   "--token", TOKEN], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env={**os.environ})
        try:
            deadline = time.monotonic() + 60
            while time.monotonic() < deadline:
                try:
                    if call(base + "/robots", timeout=2)[0] == 200:
                        break
                except OSError:
                    time.sleep(0.3)
            stored = {r["name"] for r in json.loads(call(base + "/robots")[1])}
            for name, urdf in (("big", lambda: robot("big", 50, args.links)), ("chain", lambda: robot("chain", 1, args.chain))):
                if name not in stored:
                    print(f"populate {name} (structure only): {populate(base, name, urdf()):.1f} s")

            before = rss_mb(server.pid)
            status, _, took = call(f"{base}/queries/low_confidence?robot=chain&threshold=1e999999999")
            print(f"threshold=1e999999999: {status} in {took:.3f} s, server memory +{rss_mb(server.pid) - before:.0f} MB")

            for which in ("first", "second"):
                status, body, took = call(f"{base}/robots/big.owl")
                print(f"{which} export of big.owl: {status} in {took:.2f} s, {len(body):,} bytes")

            exported: dict[str, tuple[int, float]] = {}
            others = [threading.Thread(target=lambda ext=ext: exported.update({ext: call(f"{base}/robots/big.{ext}")[::2]}))
                      for ext in ("owl", "nt")]
            for t in others:
                t.start()
            status, body, took = correction(base, "chain", {"action": "add", "class": "MonocularCamera",
                                                            "links": [f"a0_l{i}" for i in range(args.chain - 1)]})
            for t in others:
                t.join()
            print(f"correction over {args.chain - 1:,} links: {status} in {took:.1f} s; meanwhile "
                  + ", ".join(f"big.{ext}: {s} in {t:.2f} s" for ext, (s, t) in exported.items()))
            for what in ("/robots/chain/corrections", "/robots/chain"):
                times = [call(base + what, headers={"Accept": "text/html"})[::2] for _ in range(2)]
                print(f"GET {what}: " + ", ".join(f"{s} in {t:.2f} s" for s, t in times))

            status, body, took = correction(base, "big", {"action": "reject", "links": made_up(1_000_000)})
            print(f"correction naming a million made-up links: {status} in {took:.2f} s, reply {len(body):,} bytes")

            stop = time.monotonic() + args.seconds
            counts = [0] * args.clients

            def export_loop(k: int) -> None:
                while time.monotonic() < stop:
                    call(f"{base}/robots/big.owl")
                    counts[k] += 1
            clients = [threading.Thread(target=export_loop, args=(k,)) for k in range(args.clients)]
            for t in clients:
                t.start()
            time.sleep(min(2.0, args.seconds / 4))
            small = populate(base, "small", robot("small", 1, 10))
            ask = call(base + "/sparql?" + urllib.parse.urlencode({"query": "ASK {}"}),
                       headers={"Accept": "application/sparql-results+json"})[2]
            for t in clients:
                t.join()
            print(f"while {args.clients} clients export big.owl: populate of a 10-link robot {small:.2f} s, "
                  f"ASK {{}} {ask:.3f} s; {sum(counts)} exports in {args.seconds:.0f} s")
        finally:
            server.terminate()
            server.wait(30)


if __name__ == "__main__":
    main()
