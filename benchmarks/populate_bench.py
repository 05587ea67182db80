"""One robot end to end and cold, `urdfkb populate --no-cache`: this checkout, or it against another revision.

Usage: python -m benchmarks.populate_bench [--urdf PR2.urdf] [--against REV] [--runs 2]

Every run is a fresh process (cold model load, result cache off, prefix-state cache off). With
--against, the revision's files (`git archive`) are laid out as an importable `urdfkb` the way
pyproject.toml's package-dir maps them, and the two versions run alternately, so both see the same
machine load. Prints each run's wall time, prompt tokens and decodes, then the medians and, with
--against, the ratio of this checkout's median to the revision's.
"""
from __future__ import annotations

import argparse
import io
import os
import re
import statistics
import subprocess
import sys
import tarfile
import tempfile
import time
import tomllib
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
SHARED = Path(os.environ.get("URDFKB_SHARED", REPO.parent / "shared"))


def importable(rev: str, root: Path) -> Path:
    """A directory to put on PYTHONPATH that imports `urdfkb` from revision `rev` of this repository."""
    src, path = root / "src", root / "path"
    archive = subprocess.run(["git", "-C", str(REPO), "archive", rev], capture_output=True, check=True).stdout
    with tarfile.open(fileobj=io.BytesIO(archive)) as tar:
        tar.extractall(src, filter="data")
    mapping = tomllib.loads((src / "pyproject.toml").read_text())["tool"]["setuptools"]["package-dir"]
    for package, folder in sorted(mapping.items()):  # "urdfkb" first, then its sub-packages
        target = path.joinpath(*package.split("."))
        target.parent.mkdir(parents=True, exist_ok=True)
        target.symlink_to(src / folder, target_is_directory=True)
    return path


def populate(urdf: Path, out: Path, pythonpath: Path | None) -> dict:
    """One cold `urdfkb populate --no-cache` process: wall time, tokens and decodes."""
    env = {**os.environ, "URDFKB_PREFIX_CACHE": "off"}
    if pythonpath is not None:
        env["PYTHONPATH"] = str(pythonpath)
    cmd = [sys.executable, "-m", "urdfkb", "populate", str(urdf), "--no-cache", "--quiet", "--format", "turtle",
           "-o", str(out)]
    start = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, env=env, cwd=out.parent)  # not the checkout
    seconds = time.perf_counter() - start
    if proc.returncode != 0:
        sys.exit(f"urdfkb failed ({proc.returncode}):\n{proc.stderr[-2000:]}")
    text = out.read_text()
    number = lambda prop: int(re.search(rf"core:{prop}\s+\"?(\d+)", text).group(1))  # noqa: E731
    return {"seconds": seconds, "tokens": number("tokensEvaluated"), "decodes": number("llmCalls")}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--urdf", type=Path, default=SHARED / "urdf" / "pr2.urdf")
    parser.add_argument("--against", metavar="REV", help="a git revision to run alternately with this checkout")
    parser.add_argument("--runs", type=int, default=2, help="runs of each version (default 2)")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="urdfkb-bench-") as tmp:
        versions = {"this checkout": None}
        if args.against:
            (Path(tmp) / "rev").mkdir()
            versions = {args.against: importable(args.against, Path(tmp) / "rev"), **versions}
        results: dict[str, list[dict]] = {name: [] for name in versions}
        for run in range(1, args.runs + 1):
            for name, pythonpath in versions.items():
                r = populate(args.urdf, Path(tmp) / "out.ttl", pythonpath)
                results[name].append(r)
                print(f"{name:>16} run {run}: {r['seconds']:6.1f} s  {r['tokens']:,} tokens  {r['decodes']} decodes",
                      flush=True)
    medians = {name: statistics.median(r["seconds"] for r in rs) for name, rs in results.items()}
    for name, seconds in medians.items():
        print(f"{name:>16} median {seconds:6.1f} s")
    if args.against:
        print(f"ratio (this checkout / {args.against}): {medians['this checkout'] / medians[args.against]:.2f}")


if __name__ == "__main__":
    main()
