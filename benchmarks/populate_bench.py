"""One robot end to end and cold, `urdfkb populate --no-cache`: this checkout, or it against another revision.

Usage: python -m benchmarks.populate_bench [--urdf PR2.urdf] [--against REV] [--runs 2] [--timings]
                                          [--warm-with OTHER.urdf ...]

Every run is a fresh process in its own empty cache root (cold model load from the shared model
folder, result cache off, prompt-state store empty: this checkout's default is on, an older
revision's default, off, is left alone). With --warm-with, each version first populates the other
robots, in a process of its own, and every timed run of that version starts from a copy of the
prompt-state store they left: the store as a user's earlier robots leave it, without any state of
the timed robot's own. With --against, the revision's files (`git archive`) are
laid out as an importable `urdfkb` the way pyproject.toml's package-dir maps them, and the two
versions run alternately, so both see the same machine load. Prints each run's wall time, peak RSS,
prompt tokens and decodes, then the medians and, with --against, the ratio of this checkout's median
to the revision's, and how the answers compare: over the questions both versions ask, how many
answers differ and the largest probability difference (0 when every score is bit-identical).
--timings prints this checkout's last `--timings` breakdown.
"""
from __future__ import annotations

import argparse
import io
import json
import os
import re
import shutil
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


def populate(urdf: Path, out: Path, pythonpath: Path | None, timings: bool = False, store: Path | None = None) -> dict:
    """One cold `urdfkb populate --no-cache` process: wall time, peak RSS, tokens, decodes, its answers.
    Its cache root (out's folder/cache) starts empty, or with a copy of the prompt-state store `store`."""
    from urdfkb.pipeline.llm.fetch import models_dir
    from urdfkb.pipeline.llm.prefix_store import SUBDIR

    root = out.parent / "cache"
    shutil.rmtree(root, ignore_errors=True)
    if store is not None:
        shutil.copytree(store, root / SUBDIR)
    env = {**os.environ, "URDFKB_CACHE": str(root), "URDFKB_MODEL_CACHE": str(models_dir())}
    env.pop("URDFKB_PREFIX_CACHE", None)  # each version's default
    env.pop("URDFKB_RESULT_CACHE", None)
    if pythonpath is not None:
        env["PYTHONPATH"] = str(pythonpath)
    trace = out.with_suffix(".jsonl")
    cmd = [sys.executable, "-m", "urdfkb", "populate", str(urdf), "--no-cache", "--quiet", "--format", "turtle",
           "-o", str(out), "--trace", str(trace)] + (["--timings"] if timings else [])
    start = time.perf_counter()
    code, stdout, stderr, max_rss_mb = run_measured(cmd, env, out.parent)  # not in the checkout
    seconds = time.perf_counter() - start
    if code != 0:
        sys.exit(f"urdfkb failed ({code}):\n{stderr[-2000:]}")
    text = out.read_text()

    def number(prop: str) -> int:
        if (match := re.search(rf"core:{prop}\s+\"?(\d+)", text)) is None:
            sys.exit(f"the populated file has no core:{prop}")
        return int(match.group(1))

    answers, restored = {}, 0
    for line in trace.read_text().splitlines():
        record = json.loads(line)
        if "distribution" in record:
            answers[record["key"]] = (record["answer"], record["distribution"])
        restored += record.get("restored_tokens", 0)  # a step's timing record
    table = stdout[stdout.find("time breakdown"):] if timings and "time breakdown" in stdout else ""
    return {"seconds": seconds, "tokens": number("tokensEvaluated"), "decodes": number("llmCalls"), "restored": restored,
            "max_rss_mb": max_rss_mb, "answers": answers, "timings": table}


def warm(urdfs: list[Path], folder: Path, pythonpath: Path | None) -> Path | None:
    """Populate `urdfs` one after another with one cache root in `folder`; the prompt-state store they left."""
    from urdfkb.pipeline.llm.prefix_store import SUBDIR

    store = folder / "store"
    folder.mkdir(parents=True, exist_ok=True)
    for urdf in urdfs:
        r = populate(urdf, folder / "out.ttl", pythonpath, store=store if store.exists() else None)
        shutil.rmtree(store, ignore_errors=True)
        if (folder / "cache" / SUBDIR).exists():
            shutil.copytree(folder / "cache" / SUBDIR, store)
        print(f"{'warming':>16}: {urdf.stem} {r['seconds']:6.1f} s", flush=True)
        if not store.exists():
            print(f"{'warming':>16}: this version keeps no prompt states; the other robots are skipped", flush=True)
            break
    return store if store.exists() else None


def compare(a: dict, b: dict) -> str:
    """How two runs' answers compare over the questions both asked."""
    common = [k for k in a if k in b]
    differ = [k for k in common if a[k][0] != b[k][0]]
    drift = max((abs(p - b[k][1].get(o, 0.0)) for k in common for o, p in a[k][1].items()), default=0.0)
    return (f"{len(common)} common questions ({len(a)} and {len(b)} asked), {len(differ)} answers differ"
            f"{' ' + str(differ[:4]) if differ else ''}, max |d p| {drift:.3g}")


def run_measured(cmd: list[str], env: dict, cwd: Path) -> tuple[int, str, str, float]:
    """Run a command: its exit code, stdout, stderr and peak resident set size in MB (from wait4)."""
    with tempfile.TemporaryFile("w+") as out, tempfile.TemporaryFile("w+") as err:
        proc = subprocess.Popen(cmd, stdout=out, stderr=err, text=True, env=env, cwd=cwd)
        _, status, usage = os.wait4(proc.pid, 0)
        proc.returncode = os.waitstatus_to_exitcode(status)
        out.seek(0)
        err.seek(0)
        return proc.returncode, out.read(), err.read(), usage.ru_maxrss / 1024


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--urdf", type=Path, default=SHARED / "urdf" / "pr2.urdf")
    parser.add_argument("--against", metavar="REV", help="a git revision to run alternately with this checkout")
    parser.add_argument("--runs", type=int, default=2, help="runs of each version (default 2)")
    parser.add_argument("--timings", action="store_true", help="print this checkout's last --timings breakdown")
    parser.add_argument("--warm-with", type=Path, nargs="+", default=[], metavar="URDF",
                        help="robots each version populates first; its timed runs start from the prompt states they left")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="urdfkb-bench-") as tmp:
        versions: dict[str, Path | None] = {"this checkout": None}
        if args.against:
            (Path(tmp) / "rev").mkdir()
            versions = {args.against: importable(args.against, Path(tmp) / "rev"), **versions}
        stores = {name: warm(args.warm_with, Path(tmp) / f"warm-{i}", pythonpath) if args.warm_with else None
                  for i, (name, pythonpath) in enumerate(versions.items())}
        results: dict[str, list[dict]] = {name: [] for name in versions}
        for run in range(1, args.runs + 1):
            for name, pythonpath in versions.items():
                r = populate(args.urdf, Path(tmp) / "out.ttl", pythonpath, args.timings and pythonpath is None, stores[name])
                results[name].append(r)
                print(f"{name:>16} run {run}: {r['seconds']:6.1f} s  peak RSS {r['max_rss_mb']:,.0f} MB  "
                      f"{r['tokens']:,} tokens ({r['restored']:,} restored)  {r['decodes']} decodes  "
                      f"(load average {os.getloadavg()[0]:.1f})", flush=True)
    medians = {name: statistics.median(r["seconds"] for r in rs) for name, rs in results.items()}
    for name, seconds in medians.items():
        print(f"{name:>16} median {seconds:6.1f} s")
        print(f"{'':>16} runs against its first: " + "; ".join(compare(results[name][0]["answers"], r["answers"])
                                                                for r in results[name][1:]))
    if args.against:
        print(f"ratio (this checkout / {args.against}): {medians['this checkout'] / medians[args.against]:.2f}")
        print(f"answers, this checkout against {args.against}: "
              f"{compare(results[args.against][0]['answers'], results['this checkout'][0]['answers'])}")
    if args.timings and results["this checkout"][-1]["timings"]:
        print(results["this checkout"][-1]["timings"])


if __name__ == "__main__":
    main()
