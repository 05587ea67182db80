"""End-to-end `urdfkb populate` with and without the on-disk prefix KV-state cache.

Usage: python -m benchmarks.prefix_cache_bench [--robot PR2.urdf] [--first TIAGO.urdf] [--reps 1]

Each round runs, as fresh processes with the result cache off (`--no-cache`), in an isolated
cache root (models linked from the real one):
  cold          the robot with an empty prefix-state cache (what a first run pays)
  first robot   another robot, which fills the prefix-state cache
  second robot  the robot again, with the cache of states warm and the result cache cold
It prints wall time, CPU time (user + system: less sensitive to other load on the machine, though
llama.cpp's spinning threads inflate it too when cores are oversubscribed), prompt tokens evaluated and decodes side by side (medians over rounds), the
size of the state cache, and how far the second-robot answers move from the cold ones (traces).
"""
from __future__ import annotations

import argparse
import json
import os
import re
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from urdfkb.pipeline.llm.fetch import models_dir
from urdfkb.pipeline.llm.prefix_store import SUBDIR, SUFFIX

REPO = Path(__file__).resolve().parents[1]
SHARED = Path(os.environ.get("URDFKB_SHARED", REPO.parent / "shared"))
URDFKB = Path(sys.executable).with_name("urdfkb")


def populate(urdf: Path, root: Path, label: str) -> dict:
    """One `urdfkb populate --no-cache` process; its wall time, tokens, decodes and trace."""
    out, trace = root / f"{label}.ttl", root / f"{label}.jsonl"
    cmd = [str(URDFKB), "populate", str(urdf), "--no-cache", "--quiet", "--format", "turtle",
           "-o", str(out), "--trace", str(trace)]
    start, cpu = time.perf_counter(), _child_cpu()
    env = {**os.environ, "URDFKB_CACHE": str(root), "URDFKB_MODEL_CACHE": str(models_dir()), "URDFKB_PREFIX_CACHE": "on"}
    proc = subprocess.run(cmd, capture_output=True, text=True, env=env)
    seconds, cpu = time.perf_counter() - start, _child_cpu() - cpu
    if proc.returncode != 0:
        sys.exit(f"{label}: urdfkb failed ({proc.returncode}):\n{proc.stderr[-2000:]}")
    text = out.read_text()
    number = lambda prop: int(re.search(rf"core:{prop}\s+\"?(\d+)", text).group(1))  # noqa: E731
    return {"seconds": seconds, "cpu": cpu, "tokens": number("tokensEvaluated"), "decodes": number("llmCalls"),
            "trace": [json.loads(line) for line in trace.read_text().splitlines()]}


def _child_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def drift(cold: list[dict], warm: list[dict]) -> str:
    """Largest probability change and answer changes between two traces of the same robot."""
    answers = [q for q in cold if "distribution" in q]
    other = {q["key"]: q for q in warm if "distribution" in q}
    changed = [q["key"] for q in answers if q["key"] in other and other[q["key"]]["answer"] != q["answer"]]
    deltas = [abs(p - other[q["key"]]["distribution"].get(o, 0.0))
              for q in answers if q["key"] in other for o, p in q["distribution"].items()]
    missing = len([q for q in answers if q["key"] not in other])
    return (f"{len(answers)} questions, max |d probability| {max(deltas, default=0):.4f}, "
            f"answers changed {len(changed)} {changed[:5]}, questions not asked again {missing}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robot", type=Path, default=SHARED / "urdf" / "pr2.urdf")
    parser.add_argument("--first", type=Path, default=SHARED / "urdf" / "tiago.urdf")
    parser.add_argument("--reps", type=int, default=1)
    args = parser.parse_args()
    models = models_dir()
    if not any(models.glob("*.gguf")):
        sys.exit(f"no model in {models}: run `urdfkb model` first")
    runs: dict[str, list[dict]] = {"cold": [], "first robot": [], "second robot": []}
    with tempfile.TemporaryDirectory(prefix="urdfkb-bench-") as tmp:
        root = Path(tmp)  # the prompt-state and result caches; the models stay where they are
        for rep in range(args.reps):
            shutil.rmtree(root / SUBDIR, ignore_errors=True)
            print(f"round {rep + 1}: load average {os.getloadavg()[0]:.1f}", file=sys.stderr, flush=True)
            runs["cold"].append(populate(args.robot, root, "cold"))
            shutil.rmtree(root / SUBDIR, ignore_errors=True)
            runs["first robot"].append(populate(args.first, root, "first"))
            runs["second robot"].append(populate(args.robot, root, "second"))
        files = list((root / SUBDIR).glob("*" + SUFFIX))
        size = sum(f.stat().st_size for f in files)
    print(f"robot {args.robot.name}, first robot {args.first.name}; {args.reps} round(s); "
          f"load average at the end {os.getloadavg()[0]:.1f}")
    print(f"{'run':<14} {'robot':<12} {'wall s':>8} {'CPU s':>8} {'tokens evaluated':>17} {'decodes':>8}")
    for label, rs in runs.items():
        robot = args.first if label == "first robot" else args.robot
        med = lambda key: statistics.median(r[key] for r in rs)  # noqa: E731
        print(f"{label:<14} {robot.stem:<12} {med('seconds'):8.1f} {med('cpu'):8.1f} {med('tokens'):17,.0f} {med('decodes'):8.0f}")
    cold, warm = runs["cold"], runs["second robot"]
    ratio = statistics.median(c["seconds"] / w["seconds"] for c, w in zip(cold, warm))
    saved = statistics.median(c["tokens"] - w["tokens"] for c, w in zip(cold, warm))
    print(f"second robot vs cold: {ratio:.2f}x faster, {saved:,.0f} fewer tokens evaluated")
    print(f"prefix-state cache after the rounds: {len(files)} files, {size / 1e6:.1f} MB")
    print(f"answers, second robot vs cold: {drift(cold[-1]['trace'], warm[-1]['trace'])}")


if __name__ == "__main__":
    main()
