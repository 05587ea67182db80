"""The server's memory after xacro jobs whose error text is huge (issue 39, case 12: 19 MB each).

Usage: python -m benchmarks.job_error_bench [--jobs 10] [--megabytes 19] [--at-once]

Starts `urdfkb serve` from this checkout (`python -m urdfkb`, a fresh store, a free loopback port; xacro
expansion inside the sandbox where bubblewrap is on PATH, else with --trust-xacro), posts `--jobs` xacro
documents of a few hundred bytes whose expansion fails with an error of `--megabytes` MB (a dictionary
looked up by a string that long), one after the other (all at once with --at-once), waits for each job, and
prints the server's resident memory (VmRSS of it and its query workers) before, at its peak and after,
its growth, and the length of one job's error as GET /jobs/<id> gives it. Every request goes to
127.0.0.1 only; every wait is bounded.
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import threading
import time
import urllib.request
from pathlib import Path

from benchmarks.security_bench import free_port, request, rss_mb

REPO = Path(__file__).resolve().parents[1]


def failing_xacro(megabytes: int) -> bytes:
    """A xacro whose expansion fails with a KeyError naming a string of `megabytes` MB (xacro echoes it)."""
    return f"""<?xml version="1.0"?>
<robot name="big" xmlns:xacro="http://www.ros.org/wiki/xacro">
  <xacro:property name="s" value="${{'a' * {megabytes * 1_000_000}}}"/>
  <xacro:property name="d" value="${{dict(b=1)}}"/>
  <link name="${{d[s]}}"/>
</robot>""".encode()


def post_and_wait(base: str, doc: bytes, errors: list[str]) -> None:
    """POST `doc` to /populate and poll its job until it ends (at most 300 s); its error goes to `errors` ("":
    it did not fail, or never ended)."""
    req = urllib.request.Request(base + "/populate?filename=big.xacro", data=doc,
                                 headers={"Content-Type": "application/xml"})
    with urllib.request.urlopen(req, timeout=30) as resp:
        job = json.load(resp)
    deadline = time.monotonic() + 300
    while job["state"] in ("queued", "running") and time.monotonic() < deadline:
        time.sleep(0.2)
        with urllib.request.urlopen(f"{base}/jobs/{job['id']}", timeout=30) as resp:
            job = json.load(resp)
    errors.append(job["errors"][0] if job["state"] == "failed" and job["errors"] else "")


def settled(base: str, pid: int) -> float:
    """The server's RSS once its query workers have started (after a query): two readings a second apart within
    1 MB (at most 30 s)."""
    request(f"{base}/sparql?query=ASK%7B%7D", headers={"Accept": "application/sparql-results+json"})
    last, deadline = rss_mb(pid), time.monotonic() + 30
    while time.monotonic() < deadline:
        time.sleep(1)
        now = rss_mb(pid)
        if abs(now - last) < 1:
            return now
        last = now
    return last


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--jobs", type=int, default=10)
    parser.add_argument("--megabytes", type=int, default=19)
    parser.add_argument("--at-once", action="store_true", help="post every job at once instead of one after the other")
    args = parser.parse_args()
    confined = shutil.which("bwrap") is not None
    with tempfile.TemporaryDirectory() as tmp:
        port = free_port()
        base = f"http://127.0.0.1:{port}"
        argv = [sys.executable, "-m", "urdfkb", "serve", "--store", str(Path(tmp) / "kb.sqlite3"), "--port", str(port)]
        env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")])}
        server = subprocess.Popen(argv + ([] if confined else ["--trust-xacro"]), stdout=subprocess.DEVNULL,
                                  stderr=subprocess.DEVNULL, env=env)
        try:
            deadline = time.monotonic() + 60
            while time.monotonic() < deadline and server.poll() is None:
                try:
                    if request(base + "/robots", timeout=2) == 200:
                        break
                except OSError:
                    time.sleep(0.3)
            doc = failing_xacro(args.megabytes)
            errors: list[str] = []
            before = peak = settled(base, server.pid)
            started = time.monotonic()
            threads = [threading.Thread(target=post_and_wait, args=(base, doc, errors)) for _ in range(args.jobs)]
            for t in threads:
                t.start()
                if not args.at_once:
                    while t.is_alive():
                        peak = max(peak, rss_mb(server.pid))
                        t.join(0.05)
            while any(t.is_alive() for t in threads):
                peak = max(peak, rss_mb(server.pid))
                time.sleep(0.05)
            seconds = time.monotonic() - started
            after = rss_mb(server.pid)
        finally:
            server.terminate()
            server.wait(30)
    print(f"{args.jobs} xacro jobs ({'at once' if args.at_once else 'one after the other'}), each failing with a "
          f"{args.megabytes} MB error, {'sandboxed (bwrap)' if confined else '--trust-xacro (no bwrap on PATH)'}:")
    print(f"  server RSS before {before:.0f} MB, peak {peak:.0f} MB, after {after:.0f} MB: "
          f"growth {after - before:.0f} MB (peak {peak - before:.0f} MB) in {seconds:.1f} s")
    print(f"  job errors as GET /jobs/<id> gives them: {sorted({len(e) for e in errors})} characters, "
          f"ending {errors[0][-48:]!r}" if errors else "  no job answered")


if __name__ == "__main__":
    main()
