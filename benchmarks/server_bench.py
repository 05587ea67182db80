"""One `urdfkb serve` populating robot after robot: each job's time, the server's memory, PR2 against a cold CLI run.

Usage: python -m benchmarks.server_bench [--robots tiago pr2 ...] [--cli-runs 1]

In an isolated cache root (the models linked from the real one; result cache off, prompt-state
cache starting empty) it starts `urdfkb serve` on a fresh store and POSTs the robots one after
another (default: TIAGo, PR2, then eight smaller truth robots: ten), waiting for each job. Per
job it prints the job's seconds (started to finished, as /jobs/<id> reports them) and the server
process's resident memory then (VmRSS, and VmHWM: its peak so far; the query workers are separate
processes, listed apart). Before and after the server session it runs PR2 as a cold
`urdfkb populate` (fresh process, empty caches) and prints its wall time and peak RSS, then PR2's
job time as a ratio of the cold CLI median, and whether the server's PR2 and the CLI's PR2 are the
same robot graph (all triples but the timestamp, wall time, tokens evaluated and decodes, which a
warm model and restored prompt states change).
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import socket
import statistics
import subprocess
import sys
import tempfile
import time
import urllib.request
from pathlib import Path

from benchmarks.populate_bench import SHARED, run_measured

ROBOTS = ["tiago", "pr2", "turtlebot3_waffle_pi", "husky", "bolt", "hyq", "panda", "so101", "kinova_jaco2", "ur5_gripper"]
VARYING = ("#generatedAt>", "#wallTimeSeconds>", "#tokensEvaluated>", "#llmCalls>")
URDFKB = Path(sys.executable).with_name("urdfkb")


def isolated_env(root: Path) -> dict:
    from urdfkb.pipeline.llm.fetch import models_dir

    return {**os.environ, "URDFKB_CACHE": str(root), "URDFKB_MODEL_CACHE": str(models_dir()),
            "URDFKB_RESULT_CACHE": str(root / "results")}


def cli_cold(urdf: Path, tmp: Path) -> dict:
    """`urdfkb populate --no-cache` in a fresh process with empty caches: wall seconds, peak RSS, the graph."""
    root = tmp / "cli-cache"
    shutil.rmtree(root, ignore_errors=True)
    out = tmp / "cli.nt"
    cmd = [str(URDFKB), "populate", str(urdf), "--no-cache", "--quiet", "--format", "ntriples", "-o", str(out)]
    start = time.perf_counter()
    code, _, stderr, max_rss_mb = run_measured(cmd, isolated_env(root), tmp)
    seconds = time.perf_counter() - start
    if code != 0:
        sys.exit(f"urdfkb populate failed:\n{stderr[-2000:]}")
    return {"seconds": seconds, "max_rss_mb": max_rss_mb, "graph": graph_lines(out.read_text())}


def graph_lines(ntriples: str) -> list[str]:
    """The robot graph's triples without what differs from run to run, blank nodes named by content."""
    import rdflib
    from rdflib.compare import to_canonical_graph

    canonical = to_canonical_graph(rdflib.Graph().parse(data=ntriples, format="nt"))
    return sorted(line for line in canonical.serialize(format="nt").splitlines()
                  if line.strip() and not any(p in line for p in VARYING))


def memory(pid: int) -> dict:
    fields = {}
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        key, _, value = line.partition(":")
        if key in ("VmRSS", "VmHWM"):
            fields[key] = int(value.split()[0]) / 1024
    return fields


def children(pid: int) -> list[int]:
    try:
        return [int(p) for p in Path(f"/proc/{pid}/task/{pid}/children").read_text().split()]
    except OSError:
        return []


def request(url: str, data: bytes | None = None, headers: dict | None = None) -> dict:
    req = urllib.request.Request(url, data=data, headers=headers or {}, method="POST" if data is not None else "GET")
    with urllib.request.urlopen(req, timeout=60) as resp:
        return json.loads(resp.read())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", nargs="+", default=ROBOTS, help="truth robot names, in order (PR2 among them)")
    parser.add_argument("--cli-runs", type=int, default=1, help="cold CLI runs of PR2 before and after the server (each)")
    args = parser.parse_args()
    pr2 = SHARED / "urdf" / "pr2.urdf"
    with tempfile.TemporaryDirectory(prefix="urdfkb-server-bench-") as name:
        tmp = Path(name)
        cli = [cli_cold(pr2, tmp) for _ in range(args.cli_runs)]
        for r in cli:
            print(f"cold CLI PR2: {r['seconds']:.1f} s, peak RSS {r['max_rss_mb']:.0f} MB  (load average {os.getloadavg()[0]:.1f})",
                  flush=True)
        root = tmp / "server-cache"
        with socket.socket() as s:
            s.bind(("127.0.0.1", 0))
            port = s.getsockname()[1]
        server = subprocess.Popen([str(URDFKB), "serve", "--store", str(tmp / "kb.sqlite3"), "--port", str(port)],
                                  env=isolated_env(root), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        base = f"http://127.0.0.1:{port}"
        jobs = []
        try:
            for _ in range(600):
                try:
                    request(f"{base}/robots")
                    break
                except OSError:
                    time.sleep(0.1)
            print(f"server up: RSS {memory(server.pid)['VmRSS']:.0f} MB", flush=True)
            for robot in args.robots:
                urdf = (SHARED / "urdf" / f"{robot}.urdf").read_bytes()
                job = request(f"{base}/populate?use_cache=false", urdf, {"Content-Type": "application/xml"})
                while job["state"] in ("queued", "running"):
                    job = request(f"{base}/jobs/{job['id']}?wait=1&timeout=30")
                if job["state"] != "succeeded":
                    sys.exit(f"{robot}: {job['state']}: {job['errors']}")
                mem = memory(server.pid)
                workers = [memory(p)["VmRSS"] for p in children(server.pid)]
                jobs.append({"robot": robot, "name": job["robot"], "seconds": job["finished"] - job["started"], **mem})
                print(f"{robot:>22}: job {jobs[-1]['seconds']:6.1f} s; server RSS {mem['VmRSS']:.0f} MB, peak {mem['VmHWM']:.0f} MB; "
                      f"query workers {', '.join(f'{w:.0f}' for w in workers)} MB  (load average {os.getloadavg()[0]:.1f})",
                      flush=True)
            name = next(j["name"] for j in jobs if j["robot"] == "pr2")
            with urllib.request.urlopen(f"{base}/robots/{name}.nt", timeout=60) as resp:
                served = graph_lines(resp.read().decode())
        finally:
            server.terminate()
            server.wait(60)
        cli += [cli_cold(pr2, tmp) for _ in range(args.cli_runs)]
        for r in cli[args.cli_runs:]:
            print(f"cold CLI PR2: {r['seconds']:.1f} s, peak RSS {r['max_rss_mb']:.0f} MB  (load average {os.getloadavg()[0]:.1f})")
    cold = statistics.median(r["seconds"] for r in cli)
    job = next(j for j in jobs if j["robot"] == "pr2")
    after = next((i for i, j in enumerate(jobs) if j["robot"] == "pr2"), 0)
    print(f"PR2 job after {', '.join(j['robot'] for j in jobs[:after]) or 'nothing'}: {job['seconds']:.1f} s; "
          f"cold CLI median {cold:.1f} s; ratio {job['seconds'] / cold:.2f}")
    same = all(r["graph"] == served for r in cli)
    print(f"server's PR2 graph {'equals' if same else 'DIFFERS FROM'} the cold CLI's ({len(served):,} triples compared)")
    first, last = jobs[0]["VmRSS"], jobs[-1]["VmRSS"]
    print(f"server RSS after {len(jobs)} robots {last:.0f} MB, after 1: {first:.0f} MB ({100 * (last / first - 1):+.1f} %); "
          f"peak {max(j['VmHWM'] for j in jobs):.0f} MB; CLI PR2 peak RSS median "
          f"{statistics.median(r['max_rss_mb'] for r in cli):.0f} MB")


if __name__ == "__main__":
    main()
