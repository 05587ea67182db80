"""Another client's latency while the server is under the attacks of issue 29, and the server's memory growth.

Usage: python -m benchmarks.security_bench [--samples 20]

Starts `urdfkb serve` (its defaults, a fresh store holding PR2 with no model: structure only) on a free
loopback port, then for each scenario sends `ASK {}` every 0.1 s from another client while the attack
runs, and prints the median and largest latency, and the growth of the server's resident memory (VmRSS
of the server and its query workers, before and at the end):
- two `ORDER BY`s over a cross product of PR2's triples at once (each needs gigabytes: --query-memory);
- four hostile 8 MB URDFs (700,000 attributes) posted at once (parsed in their jobs, refused by the cap).
Every request goes to 127.0.0.1 only; every loop is bounded in count and time.
"""
from __future__ import annotations

import argparse
import os
import socket
import statistics
import subprocess
import sys
import tempfile
import threading
import time
import urllib.error
import urllib.parse
import urllib.request
from pathlib import Path

from benchmarks.populate_bench import SHARED

URDFKB = Path(sys.executable).with_name("urdfkb")
CROSS = "SELECT * WHERE { ?a ?b ?c . ?d ?e ?f } ORDER BY ?c ?f"


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def request(url: str, data: bytes | None = None, headers: dict | None = None, timeout: float = 30.0) -> int:
    req = urllib.request.Request(url, data=data, headers=headers or {})
    try:
        with urllib.request.urlopen(req, timeout=timeout) as resp:
            resp.read()
            return resp.status
    except urllib.error.HTTPError as e:
        return e.code


def rss_mb(pid: int) -> float:
    """Resident memory of `pid` and its children (the query workers), in MB."""
    total = 0
    for p in [pid, *_children(pid)]:
        try:
            total += int(next(line for line in open(f"/proc/{p}/status") if line.startswith("VmRSS")).split()[1])
        except (OSError, StopIteration):
            pass
    return total / 1024


def _children(pid: int) -> list[int]:
    try:
        return [int(c) for c in open(f"/proc/{pid}/task/{pid}/children").read().split()]
    except OSError:
        return []


def hostile_urdf() -> bytes:
    attrs = " ".join(f'a{i}="1"' for i in range(100))
    return ('<robot name="big"><link name="l"/>' + f"<g {attrs}/>" * 7_000 + "</robot>").encode() + b" " * 2_500_000


def under_attack(base: str, pid: int, attack, samples: int) -> tuple[list[float], float]:
    """ASK latencies (s) while `attack()` runs in threads, and the server's memory growth (MB)."""
    before = rss_mb(pid)
    threads = attack()
    for t in threads:
        t.start()
    ask = base + "/sparql?" + urllib.parse.urlencode({"query": "ASK {}"})
    latencies, peak = [], before
    for _ in range(samples):
        start = time.perf_counter()
        request(ask, headers={"Accept": "application/sparql-results+json"})
        latencies.append(time.perf_counter() - start)
        peak = max(peak, rss_mb(pid))
        time.sleep(0.1)
    for t in threads:
        t.join(60)
    return latencies, peak - before


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--samples", type=int, default=20)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        port = free_port()
        base = f"http://127.0.0.1:{port}"
        server = subprocess.Popen([str(URDFKB), "serve", "--store", str(Path(tmp) / "kb.sqlite3"), "--port", str(port)],
                                  stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env={**os.environ})
        try:
            deadline = time.monotonic() + 60
            while time.monotonic() < deadline:
                try:
                    if request(base + "/robots", timeout=2) == 200:
                        break
                except OSError:
                    time.sleep(0.3)
            xml = {"Content-Type": "application/xml"}
            pr2 = (SHARED / "urdf" / "pr2.urdf").read_bytes()
            request(base + "/populate?structure_only=true&name=pr2", pr2, xml)
            time.sleep(8)  # the structure-only job stores PR2
            sparql = {"Content-Type": "application/sparql-query"}
            doc = hostile_urdf()
            scenarios = {
                "two cross-product ORDER BYs": lambda: [
                    threading.Thread(target=request, args=(base + "/sparql", CROSS.encode(), sparql)) for _ in range(2)],
                "four hostile 8 MB URDFs posted": lambda: [
                    threading.Thread(target=request, args=(base + "/populate", doc, xml)) for _ in range(4)],
            }
            print(f"{'scenario':34s} {'ASK p50':>9s} {'ASK max':>9s} {'RSS growth':>11s}")
            for name, attack in scenarios.items():
                latencies, growth = under_attack(base, server.pid, attack, args.samples)
                print(f"{name:34s} {statistics.median(latencies):8.3f}s {max(latencies):8.3f}s {growth:9.0f} MB")
        finally:
            server.terminate()
            server.wait(30)


if __name__ == "__main__":
    main()
